#include "ptir/optim/patch_batch.h"

#include <algorithm>

namespace ptir {

PatchBatch default_patch_batch(int width, int height, int views_in_dataset) {
  PatchBatch b;
  const double batch_pixels = double(kDefaultPatchSide) * kDefaultPatchSide * kDefaultPatchViews;
  // A view of up to twice the batch's pixels: whole views. Measured on the textured 128² set
  // (16384 pixels, 800 x 8; docs/performance.md#time-to-quality): patches cost what a whole view
  // does there (they sit on the object, half a view's samples escape at once) and lost 0.55 dB
  // albedo / 0.17 dB relight to whole views.
  if (double(width) * height <= 2.0 * batch_pixels) return b;
  b.side = kDefaultPatchSide;
  b.views = std::max(1, std::min(kDefaultPatchViews, views_in_dataset));
  return b;
}

void resolve_patch_batch(int width, int height, int views_in_dataset, int* views_per_iteration, int* crop_size) {
  const PatchBatch b = default_patch_batch(width, height, views_in_dataset);
  if (*views_per_iteration == 0) *views_per_iteration = *crop_size > 0 || *crop_size < 0 ? b.views : 1;
  if (*crop_size < 0) *crop_size = b.side;
}

}  // namespace ptir
