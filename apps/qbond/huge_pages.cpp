#include "huge_pages.hpp"

#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

namespace qbond::cli {

void use_huge_pages(int argc, char** argv) {
  // Only the commands that build worlds: another start costs the others a tenth of a second or more.
  const std::string command = argc > 1 ? argv[1] : "";
  if (command != "run" && command != "bench" && command != "view" && command != "experiment" && command != "statics")
    return;
  if (std::getenv("GLIBC_TUNABLES") || std::getenv("QBOND_NO_HUGE_PAGES")) return;  // the user's choice
  if (const char* preload = std::getenv("LD_PRELOAD"); preload && std::strstr(preload, "vgpreload")) return;
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string modes;
  if (!std::getline(in, modes) || modes.find("[madvise]") == std::string::npos) return;
  if (setenv("GLIBC_TUNABLES", "glibc.malloc.hugetlb=1", 1) != 0) return;
  execv("/proc/self/exe", argv);
  unsetenv("GLIBC_TUNABLES");  // the exec failed: go on as we are
}

bool huge_pages_asked() {
  const char* t = std::getenv("GLIBC_TUNABLES");
  return t && (std::strstr(t, "glibc.malloc.hugetlb=1") || std::strstr(t, "glibc.malloc.hugetlb=2"));
}

}  // namespace qbond::cli
