// The optimiser's checkpoints (capture and restore of its state; the file
// format is checkpoint.h) and the loop that writes them (run_optimizer).
#include <filesystem>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/optim/optimizer.h"

namespace ptir {

namespace fs = std::filesystem;

Checkpoint Optimizer::checkpoint() const {
  Checkpoint c;
  c.iteration = uint64_t(iteration_);
  c.fingerprint = fingerprint();
  for (size_t i = 0; i < params_.groups.size(); ++i) {
    CheckpointGroup g;
    g.kind = params_.groups[i].kind;
    g.lr = params_.groups[i].lr;
    g.raw = params_.groups[i].raw;
    g.m = adam_[i].m;
    g.v = adam_[i].v;
    g.adam_t = adam_[i].t;
    c.groups.push_back(std::move(g));
  }
  c.normals = scene_->gaussians->normal;
  c.log = log_;
  return c;
}

void Optimizer::restore(const Checkpoint& c, const std::string& path) {
  if (c.averaged > 0)
    throw Error(path, std::string("checkpoint was written with --average-from, which was measured, lost and removed ") +
                          "(docs/inversion.md); ptir at commit " + kLastCommitWithRetiredOptions +
                          " still resumes it (git checkout " + kLastCommitWithRetiredOptions + ")");
  Fingerprint stored = c.fingerprint;
  retire_fingerprint_entries(path, stored);
  check_fingerprint(path, stored, fingerprint());
  if (c.groups.size() != params_.groups.size()) throw Error(path, "checkpoint has a different set of parameter groups");
  for (size_t i = 0; i < c.groups.size(); ++i) {
    const CheckpointGroup& g = c.groups[i];
    if (g.kind != params_.groups[i].kind || g.raw.size() != params_.groups[i].raw.size())
      throw Error(path, std::string("checkpoint parameter group '") + param_kind_name(g.kind) + "' does not match");
  }
  if (c.normals.size() != scene_->gaussians->size()) throw Error(path, "checkpoint has a different Gaussian count");
  for (size_t i = 0; i < c.groups.size(); ++i) {
    const CheckpointGroup& g = c.groups[i];
    params_.groups[i].raw = g.raw;
    params_.groups[i].lr = g.lr;
    adam_[i].lr = g.lr;
    adam_[i].m = g.m;
    adam_[i].v = g.v;
    adam_[i].t = g.adam_t;
  }
  scene_->gaussians->normal = c.normals;
  iteration_ = int(c.iteration);
  log_ = c.log;
  apply();
}

RunResult run_optimizer(Optimizer& opt, const RunOptions& o) {
  return run_iterations<Optimizer, IterationLog>(opt, o.out_dir, o.checkpoint_every, o.on_iteration, o.cancel,
                                                 [&](const std::string& path) { opt.save_checkpoint(path); });
}

}  // namespace ptir
