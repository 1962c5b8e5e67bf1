// A job's output folder as a unit: the files a long job (optimize, fit) leaves
// at the top of its folder are either all of this run (it finished or was
// cancelled, and every write went through) or all as they were before it (it
// failed: a full disk, an I/O error, any exception), never a new checkpoint
// beside an old result.
//
// How: on start, every regular file at the top of the folder gets a second name
// (a hard link; a copy where the file system has none), so the run's atomic
// writes replace the folder's names but not the kept data. commit() drops the
// kept names; without it (an exception unwinding) the kept files are renamed
// back over the new ones and the files this run added are removed. The kept
// names follow atomic_file.h's temp pattern, so a run killed with -9 (its
// periodic checkpoint meant for --resume) leaves them for remove_stale_temps().
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace ptir::io {

class OutputRollback {
 public:
  explicit OutputRollback(const std::string& dir);
  ~OutputRollback();
  OutputRollback(const OutputRollback&) = delete;
  OutputRollback& operator=(const OutputRollback&) = delete;
  void commit();

 private:
  std::string dir_;
  std::vector<std::string> before_;                       // names at the start
  std::vector<std::pair<std::string, std::string>> kept_;  // name, kept copy
  bool committed_ = false;
};

}  // namespace ptir::io
