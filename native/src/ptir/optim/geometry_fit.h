// The geometry stage (docs/method.md §9, the paper's stage 1): Adam on every Gaussian's
// position, log scale, rotation, opacity (logit) and SH radiance through our own
// ray-traced compositing (render/splat_composite.h: the k-buffer walk and response
// of rendering, gradients by a front-to-back replay), plus a free per-Gaussian
// shading normal supervised by pseudo-normals of the rendered depth.
//
// One iteration (0-based `it`):
//   1. one training view: position it % N of a permutation drawn for epoch it / N.
//   2. the render, one ray through each pixel centre: display-space colour
//      C = sum w_i c_i (SH colour as 3DGS trainers fit it to sRGB photos) over a
//      black background, opacity O, normal sum, depth.
//   3. loss = (1 - 0.2) L1 + 0.2 D-SSIM (optim/losses, no blur: there is no path
//      noise) between C and the target in display space composited on black
//      (alpha * srgb(rgb)); with a mask (target alpha): + lambda_mask * mean |O - alpha|;
//      after normal_from iterations: + lambda_normal * mean (1 - N . N_pseudo) over
//      pixels whose pseudo-normal exists (optim/pseudo_normals.h), N = the
//      normalised normal sum. The pseudo-normals are held fixed (no gradient to depth).
//      + lambda_distortion * mean Ldist / extent (the depth distortion).
//   4. the replay backward, the chain rule into the raw parameters (quaternions and
//      normals are normalised on use: their gradients are projected), one Adam
//      step per group.
//   5. every reorient_every iterations (and in the written PLY): the free normals'
//      signs re-voted by the training cameras that see them (reorient_fit_normals).
//   6. every densify_every iterations in [densify_from, densify_until): prune
//      Gaussians with opacity < prune_opacity; clone (small) or split in two (large,
//      scales / 1.6, positions drawn from the Gaussian) those whose mean positional
//      gradient, in 3DGS's screen units, exceeds densify_grad; the count stays
//      <= max_gaussians and grows at most densify_fraction per step. Reported.
//
// Determinism: views, splits and renders are keyed on (seed, iteration); the
// backward sums fixed row chunks in order: a resumed run is bit-identical to an
// uninterrupted one on the same thread count.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/optim/adam.h"
#include "ptir/optim/checkpoint.h"
#include "ptir/optim/losses.h"
#include "ptir/optim/optimizer.h"  // RunResult
#include "ptir/optim/parameters.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

struct SplatImage;  // render/splat_composite.h

struct GeometryFitSettings {
  int iterations = 3000;
  uint64_t seed = 0;
  ImageLossSettings loss{0.2f, false};
  float lambda_mask = 0.1f;
  // Off by default: measured on the dataset maker's Cycles sets at 100^2, the fitted
  // field's depth pseudo-normals (22 degrees from the truth) pull the normals away
  // (normal MAE 9.2 degrees without the term, 13.2 per-hit, 17.5 per-hit on pixels
  // > 45 degrees off; 15.4 / 23.0 in the first measurements). docs/geometry.md.
  float lambda_normal = 0.0f;
  int normal_from = 0;  // iteration from which the pseudo-normal term applies
  int normal_radius = 2;  // stencil radius of the pseudo-normals (pixels)
  bool median_depth = true;  // pseudo-normals from the median depth (else the mean, Dsum / O)
  bool normal_to_weights = false;  // the normal term moves the splats too (else only the normals)
  bool normal_per_hit = false;  // per-hit weighted loss (pseudo_normals.h) instead of the blend's
  float normal_outlier_deg = 0.0f;  // > 0: only pixels this far from their pseudo-normal are supervised
  // Weight of the depth-distortion term, from distortion_from on: mean over pixels of
  // Ldist / extent (render/splat_composite.h; Mip-NeRF 360's, 2DGS's), which gathers
  // each ray's weights at one depth, so the field's depth flattens onto one layer and
  // its pixels blend the normals of that layer, not of a cloud around it. Measured on
  // the perturbed 100^2 sample (1500 iterations; docs/geometry.md): normal MAE
  // 9.2 (off) -> 6.7 / 6.1 / 6.4 / 7.1 degrees at 3 / 10 / 30 / 100, NVS 33.2 ->
  // 33.4 / 32.9 / 31.8 / 28.9 dB; from iteration 300 instead of 0: 8.1 degrees.
  float lambda_distortion = 10.0f;
  int distortion_from = 0;
  // Adam learning rates (3DGS's; position scaled by the cameras' extent).
  float lr_position = 1.6e-4f, lr_scale = 5e-3f, lr_rotation = 1e-3f, lr_opacity = 0.05f;
  float lr_sh_dc = 2.5e-3f, lr_sh_rest = 1.25e-4f, lr_normal = 1e-3f;
  // Densification and pruning.
  // (Fixed iteration numbers, not fractions of the run: a resumed run may go further.)
  int densify_every = 100, densify_from = 200, densify_until = 1500;
  float densify_grad = 2e-4f;      // mean |dL/d(screen position)| (3DGS NDC units)
  float densify_fraction = 0.05f;  // at most this share of the count added per step
  float prune_opacity = 0.005f;
  float split_scale = 0.01f;       // split (else clone) above this share of the extent
  size_t max_gaussians = 0;        // 0: 1.5 x the initial count
  // Every this many iterations, and in the written PLY (0: never), the free normals are
  // re-oriented toward the training cameras that see them on the current field (sign only;
  // unseen ones keep theirs): the initial orientation was voted on the input's visibility,
  // and a Gaussian hidden then (jittered inward, or a floater) that the fit brings to the
  // surface would otherwise keep a normal facing into it and cancel its neighbours' in every
  // blend. (The output's pass works on a copy: a resumed run stays bit-identical.)
  int reorient_every = 100;
  // The resolution pyramid (view_pyramid.h), as the inversion's: views larger than
  // coarse_pixels are fitted reduced by a power of two until the last fine_fraction of
  // the iterations (0: off).
  int coarse_pixels = 0;
  float fine_fraction = 0.25f;
  AccelSettings accel;
};

// One row of the fit's log.csv.
struct FitLog {
  int iteration = 0;  // 1-based
  double loss = 0, image = 0, mask = 0, normal = 0, distortion = 0;
  size_t gaussians = 0;
  int pruned = 0, cloned = 0, split = 0;  // densification at this iteration
  int flipped = 0;  // normals re-oriented at this iteration (progress only; not in log.csv)
  double seconds = 0;  // wall time of the iteration, of which:
  double build_s = 0, forward_s = 0, backward_s = 0;  // BVH build, render + loss, replay + update
  size_t view = 0;
  int level = 1;  // the pyramid's reduction factor of the view (not in log.csv)
};

class GeometryFit {
 public:
  // `field`: the imported splats (normals from the file, else the shortest axis
  // oriented toward the training cameras).
  GeometryFit(GaussianField field, std::shared_ptr<const Dataset> dataset, const GeometryFitSettings& settings);

  int iteration() const { return iteration_; }
  const GeometryFitSettings& settings() const { return settings_; }
  void set_iterations(int n) { settings_.iterations = n; }
  // The pyramid's share at full resolution (a budget's plan, budget_plan.h), before its
  // first full-resolution iteration; it is in the fingerprint, so checkpoints carry it.
  void set_fine_fraction(float f) { settings_.fine_fraction = f; }
  const GaussianField& field() const { return field_; }
  const std::vector<FitLog>& log() const { return log_; }
  float extent() const { return extent_; }

  FitLog step(const std::atomic<bool>* cancel = nullptr);
  // The pyramid's reduction factor of iteration `it` (1: full resolution), its coarse
  // factor and the share of the iterations at it (0: none).
  int level_factor(int it) const;
  int coarse_factor() const;
  double coarse_share() const { return coarse_factor() > 1 ? 1.0 - double(settings_.fine_fraction) : 0.0; }

  Fingerprint fingerprint() const;
  Checkpoint checkpoint() const;
  void restore(const Checkpoint& c, const std::string& path_for_messages = "checkpoint");

  // OUT/gaussians.ply (standard 3DGS layout + nx,ny,nz and the material columns
  // the input had) and OUT/log.csv, atomically.
  void write_outputs(const std::string& dir) const;
  std::string log_csv() const;

 private:
  friend struct FitDensify;
  void apply();                       // raw -> field_
  void densify(int it, FitLog& log);  // geometry_fit_densify.cpp
  void reorient_normals(FitLog& log);
  Image normal_target(const Camera& cam, const SplatImage& fwd) const;
  size_t view_of(int it) const;
  std::shared_ptr<const TrainingImage> target_at(size_t view, int f) const;  // reduced by f (cached)

  GeometryFitSettings settings_;
  std::shared_ptr<const Dataset> dataset_;
  GaussianField field_;
  std::vector<ParameterGroup> groups_;  // position, log scale, rotation, opacity, SH dc, SH rest, normal
  std::vector<Adam> adam_;
  std::vector<float> grad_accum_, grad_count_;  // densification statistics per Gaussian
  std::vector<FitLog> log_;
  size_t initial_count_ = 0;
  float extent_ = 1.0f;
  int iteration_ = 0;
  mutable int reduced_factor_ = 1;
  mutable std::vector<std::shared_ptr<const TrainingImage>> reduced_;  // per view, at reduced_factor_
};

// reorient_fit_normals: flips the field's normals toward the cameras' votes (unseen keep
// their sign), whatever their origin; returns the flipped indices.
std::vector<size_t> reorient_fit_normals(GaussianField& field, const std::vector<Camera>& cameras,
                                         const AccelSettings& settings);

struct FitRunOptions {
  std::string out_dir;
  int checkpoint_every = 200;
  std::function<bool(const FitLog&)> on_iteration;
  const std::atomic<bool>* cancel = nullptr;
};

// Runs to settings().iterations (or a cancel); writes OUT/checkpoint.bin and the outputs.
RunResult run_geometry_fit(GeometryFit& fit, const FitRunOptions& options);

}  // namespace ptir
