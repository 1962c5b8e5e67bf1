// The parallel adjoint passes (render_path_backward, render_aov_backward) as a
// pipeline over fixed pixel tiles: each tile runs on one thread into its own
// sparse GradientTile, and the tiles are added into the dense gradients one at a
// time in tile order (TBB serial_in_order stage) while later tiles run.
//
// Decision: the tiling (gradient_tile_side square, row-major) depends on the
// image size only, not on the thread count, and each tile is summed in its own fixed order, so the
// gradients are the same floats for a seed on 1 or 64 threads. Memory is the
// tiles in flight (kTokensPerThread per thread) times what one tile touches,
// instead of a full copy of the gradients per thread; the serial stage costs
// one addition per (tile, Gaussian touched), which is small next to the paths
// that touched it.
#pragma once

#include <functional>

#include "ptir/core/render_control.h"
#include "ptir/transport/gradient_tile.h"

namespace ptir {

// Pixels per tile side: 16, halved (down to 4) while the image has fewer than
// 64 tiles, so that small images and crops still spread over the threads.
int gradient_tile_side(int width, int height);

// Tiles in flight per worker thread: enough that a slow tile holding up the
// in-order stage does not starve the others; the buffers in memory are at most this many per thread.
constexpr int kTokensPerThread = 2;

struct PixelTile {
  int x0, y0, x1, y1;  // [x0, x1) x [y0, y1)
};

struct TileReduceStats {
  size_t tiles = 0;
  size_t entries = 0;          // Gaussian entries summed over tiles
  size_t peak_tile_bytes = 0;  // largest single tile buffer
  size_t buffers = 0;          // tile buffers allocated (<= tiles in flight)
  double stage_seconds = 0.0;  // wall time in the in-order stage (adding tiles into the gradients)
};

// Runs work(tile, buffer) for every tile of a width x height image and adds
// the buffers into `grads` in tile order. Progress is reported per tile;
// cancellation stops handing out tiles and throws Cancelled.
void reduce_gradient_tiles(int width, int height, const SceneEnvironment& env, SceneGradients& grads,
                           const RenderControl& control, const std::function<void(const PixelTile&, GradientTile&)>& work,
                           TileReduceStats* stats = nullptr);

}  // namespace ptir
