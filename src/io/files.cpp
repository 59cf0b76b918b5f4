#include "qbond/io/files.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace qbond {
namespace {

[[noreturn]] void fail(const std::string& what, const std::filesystem::path& path) {
  throw std::runtime_error("cannot " + what + " " + path.string() + ": " + std::strerror(errno));
}

// Writes all of `bytes`, retrying short writes and interrupted calls.
bool write_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

}  // namespace

void write_file_atomic(const std::filesystem::path& path, std::string_view bytes, Durability durability) {
  const bool sync = durability == Durability::durable;
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : ".";
  // A hidden name beside the target: same file system, so the rename is atomic.
  std::string name = path.filename().string();
  name.insert(name.begin(), '.');
  name += ".tmp." + std::to_string(::getpid());
  const std::filesystem::path tmp = dir / name;
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("create", tmp);
  if (!write_all(fd, bytes) || (sync && ::fsync(fd) != 0)) {
    const int saved = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    errno = saved;
    fail("write", tmp);
  }
  if (::close(fd) != 0 || ::rename(tmp.c_str(), path.c_str()) != 0) {
    const int saved = errno;
    ::unlink(tmp.c_str());
    errno = saved;
    fail("write", path);
  }
  // The rename itself is durable only once the directory is synced.
  if (!sync) return;
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

void flush_file_system(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail("open", dir);
  const int status = ::syncfs(fd);
  const int saved = errno;
  ::close(fd);
  errno = saved;
  if (status != 0) fail("flush", dir);
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail("read", path);
  std::ostringstream s;
  s << in.rdbuf();
  return std::move(s).str();
}

LineFile::LineFile(const std::filesystem::path& path, bool truncate) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC | (truncate ? O_TRUNC : 0), 0644);
  if (fd_ < 0) fail("open", path);
}

LineFile::~LineFile() {
  if (fd_ >= 0) ::close(fd_);
}

void LineFile::write_line(std::string_view line) {
  buffer_.assign(line);
  buffer_ += '\n';
  if (!write_all(fd_, buffer_)) fail("write", path_);
}

}  // namespace qbond
