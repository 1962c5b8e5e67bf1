// The iteration loop with checkpoints and outputs, shared by the material
// inversion (run_optimizer) and the geometry stage (run_geometry_fit).
//
// Runs job.step() until job.settings().iterations, a cancel flag, or the
// on_iteration callback returning false. Every checkpoint_every iterations
// (not at the last) it saves the checkpoint and OUT/log.csv; at the end,
// finished or cancelled, the checkpoint and job.write_outputs(OUT). With an
// empty out_dir nothing is written. A run that throws leaves the folder's files
// as they were before it (io/output_rollback.h).
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/output_rollback.h"

namespace ptir {

enum class RunResult { Finished, Cancelled };

template <class Job, class Log>
RunResult run_iterations(Job& job, const std::string& out_dir, int checkpoint_every,
                         const std::function<bool(const Log&)>& on_iteration, const std::atomic<bool>* cancel,
                         const std::function<void(const std::string& path)>& save_checkpoint) {
  namespace fs = std::filesystem;
  const bool write = !out_dir.empty();
  const std::string ckpt = write ? (fs::path(out_dir) / "checkpoint.bin").string() : "";
  if (write) {
    std::error_code ec;
    fs::create_directories(out_dir, ec);
    if (!fs::is_directory(out_dir)) throw Error(out_dir, "cannot create the output folder");
  }
  // A run that fails (a full disk, any error) leaves the folder's previous result and checkpoint as they were.
  std::optional<io::OutputRollback> rollback;
  if (write) rollback.emplace(out_dir);
  bool cancelled = false;
  while (job.iteration() < job.settings().iterations) {
    if (cancel && cancel->load()) {
      cancelled = true;
      break;
    }
    Log log;
    try {
      log = job.step(cancel);
    } catch (const Cancelled&) {
      cancelled = true;
      break;
    }
    const bool go_on = on_iteration ? on_iteration(log) : true;
    if (write && checkpoint_every > 0 && job.iteration() % checkpoint_every == 0 &&
        job.iteration() < job.settings().iterations) {
      save_checkpoint(ckpt);
      io::write_text_atomic((fs::path(out_dir) / "log.csv").string(), job.log_csv());
    }
    if (!go_on) {
      cancelled = true;
      break;
    }
  }
  if (write) {
    save_checkpoint(ckpt);
    job.write_outputs(out_dir);
    rollback->commit();
  }
  return cancelled ? RunResult::Cancelled : RunResult::Finished;
}

}  // namespace ptir
