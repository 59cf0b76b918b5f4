#pragma once
/// Output files that never show a reader half a write.
#include <filesystem>
#include <string>
#include <string_view>

namespace qbond {

/// How far write_file_atomic goes: `atomic`, a reader sees the old file or the new one, never
/// part of one; `durable`, also flushed to the disk (the file and its directory synced), so that
/// it survives a crash of the machine too. A run's frames are only atomic, and flushed together
/// before each checkpoint (flush_file_system): flushing two files every frame can cost a small
/// scene (liquid_blob) as much as its steps.
enum class Durability { atomic, durable };

/// Writes `bytes` to a temporary file beside `path` and renames it over `path` (atomic on POSIX),
/// syncing both first when `durability` asks. Throws std::runtime_error naming the path and the
/// system error.
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes,
                       Durability durability = Durability::durable);

/// Flushes to the disk everything written so far to the file system that holds `dir` (syncfs):
/// one call where a file-by-file flush would take two each. Throws std::runtime_error naming the
/// directory when it cannot.
void flush_file_system(const std::filesystem::path& dir);

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
