#include "ptir/render/material_maps.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "ptir/core/error.h"
#include "ptir/math/rng.h"

namespace ptir {

void render_material_maps(const SceneAccel& accel, const Camera& camera, const AovSettings& settings,
                          const RenderControl& control, Image* albedo, Image* roughness, Image* coverage,
                          MaterialMapWalks* walks) {
  constexpr int kRows = MaterialMapWalks::kRows, kLanes = kRows * kRows;
  const int width = camera.width, height = camera.height;
  *albedo = Image(width, height, {"R", "G", "B"});
  *roughness = Image(width, height, {"Y"});
  *coverage = Image(width, height, {"A"});
  const int n_bands = (height + kRows - 1) / kRows;
  if (walks) {
    walks->width = width, walks->height = height;
    walks->bands.resize(size_t(n_bands));
    walks->pixels.assign(size_t(width) * height, {});
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, n_bands), [&](const tbb::blocked_range<int>& r) {
    if (control.cancel && control.cancel->load()) return;
    AovWalk lane_walks[kLanes];
    for (int band = r.begin(); band < r.end(); ++band) {
      const int y0 = band * kRows, y1 = std::min(height, y0 + kRows);
      if (walks) walks->bands[size_t(band)].clear();
      // Blocks of kRows x kRows pixel centres, traced as one packet (the same
      // hits and floats as one ray at a time: trace_aov_packet).
      for (int x0 = 0; x0 < width; x0 += kRows) {
        int xs[kLanes], ys[kLanes], n = 0;
        Ray rays[kLanes];
        uint64_t keys[kLanes];
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < std::min(width, x0 + kRows); ++x) {
            xs[n] = x, ys[n] = y;
            rays[n] = camera.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
            keys[n] = Rng(settings.seed, camera.full_pixel_index(x, y), 0).key();
            n++;
          }
        AovSample smp[kLanes];
        trace_aov_packet(accel, rays, n, settings, keys, false, smp, nullptr, walks ? lane_walks : nullptr);
        for (int l = 0; l < n; ++l) {
          const size_t p = size_t(ys[l]) * width + xs[l];
          if (smp[l].hit) {
            albedo->pixels[3 * p] = smp[l].albedo.x;
            albedo->pixels[3 * p + 1] = smp[l].albedo.y;
            albedo->pixels[3 * p + 2] = smp[l].albedo.z;
            roughness->pixels[p] = smp[l].roughness;
          }
          coverage->pixels[p] = std::min(1.0f, smp[l].opacity);
          if (walks) {
            // The lane's hits appended to its band; the mesh only where it ended the walk.
            std::vector<GaussianHit>& kept = walks->bands[size_t(band)];
            const AovWalk& w = lane_walks[l];
            MaterialMapWalks::Pixel& px = walks->pixels[p];
            px.first = uint32_t(kept.size());
            px.count = uint32_t(w.hits.size());
            px.mesh = (!w.end.stopped && w.end.mesh.valid) ? int32_t(w.end.mesh.mesh) : -1;
            kept.insert(kept.end(), w.hits.begin(), w.hits.end());
          }
        }
      }
    }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
}

}  // namespace ptir
