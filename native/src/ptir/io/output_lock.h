// One writer per output folder: an advisory lock (flock) on DIR/.ptir-lock, held
// by the command that writes DIR for as long as it runs. A second command on the
// same folder fails at once with an error naming the holder (its pid and command,
// which the lock file holds). The kernel releases the lock when its holder exits
// in any way (kill -9 included), so a lock is never stale after its owner's death;
// a clean release also removes the file, so a finished folder holds no lock file.
//
// The protocol (lock, then check that the path still names the locked file;
// unlink while holding) keeps one holder even when a release removes the file
// between another process's open and its lock.
#pragma once

#include <string>

namespace ptir::io {

// The lock file's name inside the folder it guards.
constexpr const char* kOutputLockName = ".ptir-lock";

class OutputLock {
 public:
  // Creates `dir` if missing and locks it for `command` (e.g. "ptir optimize").
  // Throws ptir::Error naming `dir` and the holder when another process holds it.
  // Where the folder cannot hold a lock file (read-only, no flock), nothing is
  // locked: the command's own writes then report what is wrong.
  OutputLock(const std::string& dir, const std::string& command);
  ~OutputLock();  // removes the lock file, releases it; removes `dir` again when it made it and it is empty
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  std::string dir_, path_;
  int fd_ = -1;
  bool created_dir_ = false;
};

}  // namespace ptir::io
