// The geometry stage's checkpoints (the optimiser's file format, checkpoint.h:
// one group per raw parameter kind with its Adam state, plus the densification
// statistics and the log rows as groups without moments), outputs and run loop.
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/optim/geometry_fit.h"
#include "ptir/optim/geometry_fit_groups.h"
#include "ptir/scene/gaussian_ply.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

constexpr int kLogFields = 15;

std::string num(double v) {
  std::ostringstream s;
  s.precision(9);
  s << v;
  return s.str();
}

}  // namespace

Fingerprint GeometryFit::fingerprint() const {
  const GeometryFitSettings& s = settings_;
  Fingerprint fp = {{"stage", "geometry"},
          {"dataset", dataset_->transforms_path},
          {"views", std::to_string(dataset_->size())},
          {"initial_gaussians", std::to_string(initial_count_)},
          {"sh_degree", std::to_string(field_.sh_degree)},
          {"seed", std::to_string(s.seed)},
          {"lambda_ssim", num(s.loss.lambda_ssim)},
          {"lambda_mask", num(s.lambda_mask)},
          {"lambda_normal", num(s.lambda_normal)},
          {"distortion", num(s.lambda_distortion) + " from " + std::to_string(s.distortion_from)},
          {"normal_from", std::to_string(s.normal_from) + " r" + std::to_string(s.normal_radius) +
                              (s.normal_to_weights ? " weights" : "") + (s.median_depth ? " median" : " mean")},
          {"lr", num(s.lr_position) + " " + num(s.lr_scale) + " " + num(s.lr_rotation) + " " + num(s.lr_opacity) + " " +
                     num(s.lr_sh_dc) + " " + num(s.lr_sh_rest) + " " + num(s.lr_normal)},
          {"densify", std::to_string(s.densify_every) + " " + std::to_string(s.densify_from) + " " +
                          std::to_string(s.densify_until) + " " + num(s.densify_grad) + " " + num(s.densify_fraction) +
                          " " + num(s.prune_opacity) + " " + num(s.split_scale) + " " + std::to_string(s.max_gaussians)},
          {"k", std::to_string(s.accel.k)}};
  // Only then: checkpoints from before the pyramid still resume.
  if (s.coarse_pixels > 0) fp.push_back({"pyramid", std::to_string(s.coarse_pixels) + " until " + num(1.0f - s.fine_fraction)});
  return fp;
}

Checkpoint GeometryFit::checkpoint() const {
  Checkpoint c;
  c.iteration = uint64_t(iteration_);
  c.fingerprint = fingerprint();
  for (size_t k = 0; k < groups_.size(); ++k)
    c.groups.push_back({groups_[k].kind, groups_[k].lr, adam_[k].t, groups_[k].raw, adam_[k].m, adam_[k].v});
  CheckpointGroup stats{ParamKind::FitStatistics, 0.0f, 0, grad_accum_, {}, {}};
  stats.raw.insert(stats.raw.end(), grad_count_.begin(), grad_count_.end());
  stats.m.assign(stats.raw.size(), 0.0f), stats.v = stats.m;  // the file holds moments for every group
  c.groups.push_back(std::move(stats));
  CheckpointGroup rows{ParamKind::FitLogRows, 0.0f, 0, {}, {}, {}};
  for (const FitLog& l : log_)
    rows.raw.insert(rows.raw.end(), {float(l.iteration), float(l.loss), float(l.image), float(l.mask), float(l.normal),
                                     float(l.gaussians), float(l.pruned), float(l.cloned), float(l.split),
                                     float(l.seconds), float(l.view), float(l.build_s), float(l.forward_s),
                                     float(l.backward_s), float(l.distortion)});
  rows.m.assign(rows.raw.size(), 0.0f), rows.v = rows.m;
  c.groups.push_back(std::move(rows));
  return c;
}

void GeometryFit::restore(const Checkpoint& c, const std::string& path) {
  check_fingerprint(path, c.fingerprint, fingerprint());
  if (c.groups.size() != groups_.size() + 2) throw Error(path, "not a geometry-fit checkpoint");
  const size_t n = c.groups[kFitOpacity].raw.size();
  const int stride = field_.sh_stride();
  for (int k = 0; k < kFitGroups; ++k) {
    const CheckpointGroup& g = c.groups[size_t(k)];
    if (g.kind != fit_group_kind(k) || g.raw.size() != n * size_t(fit_group_width(k, stride)) ||
        g.m.size() != g.raw.size() || g.v.size() != g.raw.size())
      throw Error(path, std::string("checkpoint parameter group '") + param_kind_name(fit_group_kind(k)) +
                            "' does not match");
  }
  const CheckpointGroup& stats = c.groups[kFitGroups];
  const CheckpointGroup& rows = c.groups[kFitGroups + 1];
  if (stats.kind != ParamKind::FitStatistics || stats.raw.size() != 2 * n || rows.kind != ParamKind::FitLogRows ||
      rows.raw.size() % kLogFields != 0)
    throw Error(path, "checkpoint statistics do not match");
  for (int k = 0; k < kFitGroups; ++k) {
    const CheckpointGroup& g = c.groups[size_t(k)];
    groups_[k].raw = g.raw;
    groups_[k].lr = g.lr;
    adam_[k].lr = g.lr;
    adam_[k].m = g.m;
    adam_[k].v = g.v;
    adam_[k].t = g.adam_t;
  }
  grad_accum_.assign(stats.raw.begin(), stats.raw.begin() + long(n));
  grad_count_.assign(stats.raw.begin() + long(n), stats.raw.end());
  log_.clear();
  for (size_t r = 0; r + kLogFields <= rows.raw.size(); r += kLogFields) {
    const float* v = &rows.raw[r];
    FitLog l;
    l.iteration = int(v[0]), l.loss = v[1], l.image = v[2], l.mask = v[3], l.normal = v[4];
    l.gaussians = size_t(v[5]), l.pruned = int(v[6]), l.cloned = int(v[7]), l.split = int(v[8]);
    l.seconds = v[9], l.view = size_t(v[10]), l.build_s = v[11], l.forward_s = v[12], l.backward_s = v[13];
    l.distortion = v[14];
    log_.push_back(l);
  }
  // The material columns (not fitted here; densification reorders them) are not
  // in the checkpoint: a resumed run whose count changed writes the defaults.
  if (field_.albedo.size() != n) {
    field_.albedo.assign(n, Vec3(kDefaultAlbedo));
    field_.roughness.assign(n, kDefaultRoughness);
    field_.metallic.assign(n, kDefaultMetallic);
    field_.specular.clear();
    field_.specular_tint.clear();
  }
  iteration_ = int(c.iteration);
  apply();
}

std::string GeometryFit::log_csv() const {
  std::ostringstream s;
  s << "iteration,loss,image,mask,normal,gaussians,pruned,cloned,split,seconds,build_s,forward_s,backward_s,view,"
       "distortion\n";
  for (const FitLog& l : log_)
    s << l.iteration << ',' << num(l.loss) << ',' << num(l.image) << ',' << num(l.mask) << ',' << num(l.normal) << ','
      << l.gaussians << ',' << l.pruned << ',' << l.cloned << ',' << l.split << ',' << num(l.seconds) << ','
      << num(l.build_s) << ',' << num(l.forward_s) << ',' << num(l.backward_s) << ',' << dataset_->views[l.view].camera.name
      << ',' << num(l.distortion) << '\n';
  return s.str();
}

void GeometryFit::write_outputs(const std::string& dir) const {
  GaussianField out = field_;
  if (settings_.reorient_every > 0) reorient_fit_normals(out, dataset_->cameras(), settings_.accel);
  out.normals_from_file = true;
  save_gaussians((fs::path(dir) / "gaussians.ply").string(), out);
  io::write_text_atomic((fs::path(dir) / "log.csv").string(), log_csv());
}

RunResult run_geometry_fit(GeometryFit& fit, const FitRunOptions& o) {
  return run_iterations<GeometryFit, FitLog>(fit, o.out_dir, o.checkpoint_every, o.on_iteration, o.cancel,
                                             [&](const std::string& path) { write_checkpoint(path, fit.checkpoint()); });
}

}  // namespace ptir
