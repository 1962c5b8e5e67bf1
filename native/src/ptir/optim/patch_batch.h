// The training signal of one inversion iteration: a batch of square patches,
// one per view, drawn across the training views (issue 38), so that an
// iteration's cost is set by the batch, not by the photos' pixel count.
//
// Before, an iteration rendered one whole view: 800 iterations x 32 spp cost 9
// minutes at 128^2 and ~9 hours for 1-MP photos, although the parameters (one
// albedo per Gaussian, the light) are the same whatever the resolution. A
// patch sees every Gaussian under it as a whole view does; several patches
// from several views average the gradient over cameras (which is what the
// light's texels need) at the cost of one small view.
//
// The side is sized for the loss's windows: the 3x3 binomial blur and the TV's
// neighbours lose a 1-pixel border, D-SSIM (when on) an 11x11 window, so 32
// pixels keep at least 2/3 of a patch's pixels inside every window. Each
// patch's centre is drawn uniformly over its view's mask box (optimizer.cpp,
// pick_views), so the object, not the background, is sampled.
#pragma once

namespace ptir {

struct PatchBatch {
  int views = 1;  // patches (views) per iteration
  int side = 0;   // square side in pixels (0: whole views)
};

// The default batch for views of width x height: whole views when a view has at
// most twice the batch's pixels (128^2 and smaller: measured, whole views won
// there), else kDefaultPatchViews patches of kDefaultPatchSide
// (docs/performance.md, "Time to quality", has the measurements).
constexpr int kDefaultPatchSide = 32;
constexpr int kDefaultPatchViews = 8;
PatchBatch default_patch_batch(int width, int height, int views_in_dataset);

// Resolves the optimiser settings' "automatic" values: views_per_iteration 0 and
// crop_size -1 take default_patch_batch's (either alone: the other's default).
void resolve_patch_batch(int width, int height, int views_in_dataset, int* views_per_iteration, int* crop_size);

}  // namespace ptir
