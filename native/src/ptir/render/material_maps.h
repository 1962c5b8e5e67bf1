// The primary-hit material maps the regularisers act on (albedo and roughness at
// each pixel centre, and the coverage), and the walks that made them, kept so
// that the maps' adjoint (aov_backward.h) rebuilds each pixel's interaction from
// its recorded hits instead of tracing the same ray again.
#pragma once

#include <cstdint>
#include <vector>

#include "ptir/render/aov.h"

namespace ptir {

// Each pixel's primary walk, as trace_aov recorded it (AovWalk): its hits, in
// bands of kRows image rows (a band is filled by one task, so the bands need no
// locking), and per pixel where they lie and which mesh ended the walk.
struct MaterialMapWalks {
  static constexpr int kRows = 4;
  struct Pixel {
    uint32_t first = 0, count = 0;  // hits[first, first + count) of the pixel's band
    int32_t mesh = -1;              // the mesh that ended the walk (not stopped by opacity), else -1
  };
  int width = 0, height = 0;
  std::vector<std::vector<GaussianHit>> bands;  // band y / kRows
  std::vector<Pixel> pixels;                    // y * width + x

  const GaussianHit* hits(int x, int y) const { return bands[size_t(y / kRows)].data() + pixel(x, y).first; }
  const Pixel& pixel(int x, int y) const { return pixels[size_t(y) * width + x]; }
};

// The albedo (RGB) and roughness (Y) maps of the primary hits, one ray through each
// pixel centre (4 x 4 pixels traced as a packet): the values render_aov(Albedo /
// Roughness) gives with spp = 1 (and what render_aov_backward differentiates),
// and the coverage min(1, opacity) (A). With `walks`, each pixel's walk is kept
// for render_aov_backward.
void render_material_maps(const SceneAccel& accel, const Camera& camera, const AovSettings& settings,
                          const RenderControl& control, Image* albedo, Image* roughness, Image* coverage,
                          MaterialMapWalks* walks = nullptr);

}  // namespace ptir
