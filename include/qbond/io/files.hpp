#pragma once
/// Output files that never show a reader half a write.
#include <cstdint>
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

/// Removes from `dir` the temporary files write_file_atomic leaves when its process is killed
/// mid-write (".NAME.tmp.PID"), those of processes no longer alive only. Returns how many.
std::size_t remove_stale_temporaries(const std::filesystem::path& dir);

/// Flushes to the disk everything written so far to the file system that holds `dir` (syncfs):
/// one call where a file-by-file flush would take two each. Throws std::runtime_error naming the
/// directory when it cannot.
void flush_file_system(const std::filesystem::path& dir);

/// The largest text input read_file takes by default (a scene, a mesh, a viewer script): 1 GiB.
inline constexpr std::uint64_t kMaxInputBytes = std::uint64_t{1} << 30;

/// A regular file open for reading. Anything else (a directory, a FIFO, a device such as
/// /dev/zero, a socket) is refused when opened, before a byte is read: such a "file" has no
/// size to check and may never end. Throws std::runtime_error naming the path and why.
class InputFile {
 public:
  explicit InputFile(const std::filesystem::path& path);
  ~InputFile();
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  /// The file's size in bytes when it was opened.
  std::uint64_t size() const { return size_; }
  /// Exactly `length` bytes from `offset`; throws std::runtime_error when the file is shorter.
  std::string read(std::uint64_t offset, std::uint64_t length) const;

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

/// The whole content of a regular file of at most `max_bytes`. Throws std::runtime_error naming
/// the path when it is missing, unreadable, not a regular file (InputFile) or larger.
std::string read_file(const std::filesystem::path& path, std::uint64_t max_bytes = kMaxInputBytes);

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
