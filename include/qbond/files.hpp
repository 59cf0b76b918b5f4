#pragma once
/// Output files that never show a reader half a write (DESIGN §10).
#include <filesystem>
#include <string>
#include <string_view>

namespace qbond {

/// Writes `bytes` to a temporary file beside `path`, syncs it and renames it over `path` (atomic
/// on POSIX). Throws std::runtime_error naming the path and the system error.
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes);

/// The whole content of a file. Throws std::runtime_error naming the path when unreadable.
std::string read_file(const std::filesystem::path& path);

/// An append-only text file (CSV) written one whole line per system call, so that a crash or a
/// signal never leaves a partial line.
class LineFile {
 public:
  /// Opens `path` for appending; `truncate` empties it first.
  LineFile(const std::filesystem::path& path, bool truncate);
  ~LineFile();
  LineFile(const LineFile&) = delete;
  LineFile& operator=(const LineFile&) = delete;
  /// Appends `line` and a newline. Throws std::runtime_error on failure.
  void write_line(std::string_view line);

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  std::string buffer_;
};

}  // namespace qbond
