#include "ptir/io/output_rollback.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include "ptir/io/atomic_file.h"
#include "ptir/io/output_lock.h"

namespace fs = std::filesystem;

namespace ptir::io {

namespace {

// Temps, and the folder's lock (output_lock.h): neither is the run's output.
bool is_temp(const std::string& name) { return name.find(".ptir-tmp-") != std::string::npos || name == kOutputLockName; }

std::vector<std::string> top_files(const std::string& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file(ec) && !is_temp(it->path().filename().string()))
      names.push_back(it->path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

OutputRollback::OutputRollback(const std::string& dir) : dir_(dir), before_(top_files(dir)) {
  for (const std::string& name : before_) {
    const fs::path file = fs::path(dir) / name;
    // ".<stem>.ptir-tmp-<pid>.keep<ext>" would not match the stale pattern; keep the pattern exactly.
    fs::path keep = atomic_temp_path(fs::path(dir) / ("kept-" + name));
    std::error_code ec;
    fs::remove(keep, ec);
    fs::create_hard_link(file, keep, ec);
    if (ec) fs::copy_file(file, keep, fs::copy_options::overwrite_existing, ec);
    if (ec) {
      std::fprintf(stderr, "warning: %s: cannot keep the previous version while the run writes (%s)\n",
                   file.c_str(), ec.message().c_str());
      continue;
    }
    kept_.emplace_back(name, keep.string());
  }
}

void OutputRollback::commit() {
  committed_ = true;
  std::error_code ec;
  for (const auto& [name, keep] : kept_) fs::remove(keep, ec);
  kept_.clear();
}

OutputRollback::~OutputRollback() {
  if (committed_) return;
  std::error_code ec;
  for (const std::string& name : top_files(dir_))  // added by this run
    if (!std::binary_search(before_.begin(), before_.end(), name)) fs::remove(fs::path(dir_) / name, ec);
  for (const auto& [name, keep] : kept_) {
    const fs::path target = fs::path(dir_) / name;
    if (fs::equivalent(keep, target, ec)) {  // not replaced by this run (rename would keep both names)
      fs::remove(keep, ec);
      continue;
    }
    fs::rename(keep, target, ec);
    if (ec) std::fprintf(stderr, "warning: cannot restore %s/%s: %s\n", dir_.c_str(), name.c_str(), ec.message().c_str());
  }
}

}  // namespace ptir::io
