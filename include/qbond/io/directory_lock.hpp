#pragma once
/// One run per output directory: the run that writes a directory holds its lock file, so that a
/// second run started into it is refused instead of interleaving its rows with the first's.
#include <filesystem>
#include <stdexcept>
#include <string>

namespace qbond {

/// The directory is held by another live process.
class DirectoryBusy : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An exclusive lock on `dir/run.lock` (flock), held for the object's lifetime. The file holds the
/// owner's process id, for the message a refused run prints. The kernel drops the lock when its
/// owner exits, however it exits: a lock file left by a killed run (a dead process id) is simply
/// taken over, and the file itself is never removed (removing it would let two runs lock two
/// different files of the same name).
class DirectoryLock {
 public:
  /// Takes the lock, or throws DirectoryBusy naming the directory and the process that holds it;
  /// std::runtime_error when the lock file cannot be made.
  explicit DirectoryLock(const std::filesystem::path& dir);
  ~DirectoryLock();
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;

  /// The lock file's name in the directory.
  static constexpr const char* kFileName = "run.lock";

 private:
  int fd_ = -1;
};

}  // namespace qbond
