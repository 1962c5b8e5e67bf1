// The time one optimiser iteration will take, estimated before the run starts
// (`ptir optimize` prints it), by measuring rather than by a model: the primal
// render and the path replay of a probe window of the first training view are
// timed and scaled to the iteration's pixels and samples.
//
// Probe: 16 windows of 24 x 24 pixels on a 4 x 4 grid over the first view (so
// object and background are sampled in proportion; one central window
// overestimated a view with much cheap background 6x), at min(spp, 4) samples,
// after an 8 x 8 warm-up render (lazy tables, first-touch memory); the replay's
// cost per sample is the primal's times the replay / primal ratio of one central
// 48 x 48 window. Scaling: per
// path sample cost x (view pixels x spp x views per iteration), plus the
// material-map regulariser (its maps and their adjoint, timed on the central
// window) per pixel, plus a replay's fixed cost (gradient buffers sized by the scene) per view. The
// iterations' own "s/iter" then tells the truth.
#pragma once

#include "ptir/optim/optimizer.h"

namespace ptir {

struct IterationEstimate {
  double seconds = 0.0;           // one iteration
  double fixed_seconds = 0.0;     // the part of it that does not scale with the spp (regulariser, replay calls)
  double primal_per_sample = 0.0;  // seconds per path sample, primal
  double replay_per_sample = 0.0;  // seconds per path sample, replay (backward)
  double replay_fixed = 0.0;       // seconds per replay call, whatever its size
  double regulariser_per_pixel = 0.0;  // seconds per view pixel, material maps + adjoint (0 when off)
  int probe_pixels = 0, probe_spp = 0;
  // With the resolution pyramid (view_pyramid.h) `seconds` is the mean over its phases:
  // a coarse iteration (the first coarse_share of the run) and a full-resolution one.
  double coarse_share = 0.0;
  double coarse_seconds = 0.0, fine_seconds = 0.0;
  double coarse_fixed_seconds = 0.0, fine_fixed_seconds = 0.0;  // their parts that do not scale with the spp
  int coarse_spp = 0, fine_spp = 0;                            // the spp they were estimated at
  // The full-resolution batch the estimate was made for: its patches (views) per iteration,
  // and whether they are the automatic batch's patches (budget_plan.h may then grow their count).
  int fine_views = 0;
  bool fine_patches_auto = false;
  double fine_view_pixels = 0.0;  // pixels of one full-resolution patch (view)
  double train_pixels = 0.0;      // the training views' pixels at full resolution, all of them
};

IterationEstimate estimate_iteration(const Optimizer& opt);

}  // namespace ptir
