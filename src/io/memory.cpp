#include "qbond/io/memory.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace qbond {

std::uint64_t available_memory() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  std::uint64_t bytes = pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page)
                                              : std::uint64_t{1} << 32;
  // A container's limit, when there is one ("max" when there is none).
  std::ifstream cgroup("/sys/fs/cgroup/memory.max");
  std::string text;
  if (cgroup >> text && !text.empty() && text != "max") {
    try {
      bytes = std::min<std::uint64_t>(bytes, std::stoull(text));
    } catch (const std::exception&) {
    }
  }
  return bytes;
}

std::uint64_t default_memory_limit() { return available_memory() / 4 * 3; }

std::uint64_t estimated_run_memory(double quanta, double bonds) {
  // Fitted to `qbond run` peaks (docs/running.md, "Memory"): per quanta, per bond (with the copy
  // of the bonds a scene with heuristics keeps to undo a step), and the program itself.
  constexpr double kPerQuanta = 1200, kPerBond = 520, kBase = 32e6;
  const double bytes = kPerQuanta * quanta + kPerBond * bonds + kBase;
  return bytes >= 1.8e19 ? ~std::uint64_t{0} : static_cast<std::uint64_t>(bytes);
}

std::string format_bytes(double bytes) {
  const char* units[] = {"B", "kB", "MB", "GB", "TB", "PB", "EB"};
  int u = 0;
  while (bytes >= 1000 && u < 6) {
    bytes /= 1000;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.3g %s", bytes, units[u]);
  return buf;
}

std::uint64_t parse_bytes(const std::string& text) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    throw std::invalid_argument("expected a size such as 8G or 512MiB, got '" + text + "'");
  }
  const std::string suffix = text.substr(used);
  double scale = 0;
  const std::pair<const char*, double> suffixes[] = {
      {"", 1},        {"B", 1},          {"k", 1e3},        {"K", 1e3},        {"M", 1e6},
      {"G", 1e9},     {"T", 1e12},       {"kB", 1e3},       {"KB", 1e3},       {"MB", 1e6},
      {"GB", 1e9},    {"TB", 1e12},      {"KiB", 1024.0},   {"MiB", 1048576.0}, {"GiB", 1073741824.0},
      {"TiB", 1099511627776.0}};
  for (const auto& [s, f] : suffixes)
    if (suffix == s) scale = f;
  if (scale == 0 || !std::isfinite(value) || value <= 0 || value * scale >= 1.8e19)
    throw std::invalid_argument("expected a positive size such as 8G or 512MiB, got '" + text + "'");
  return static_cast<std::uint64_t>(value * scale);
}

}  // namespace qbond
