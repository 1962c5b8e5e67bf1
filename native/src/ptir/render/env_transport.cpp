#include "ptir/render/env_transport.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <memory>

#include "ptir/core/error.h"
#include "ptir/lights/environment.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/render/camera_sample.h"
#include "ptir/transport/gradient_tile.h"

namespace ptir {

void render_env_transport(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                          int band_rows, const std::function<void(int, const EnvTransportPixel&)>& visit,
                          const RenderControl& control) {
  if (settings.spp < 2) throw Error("the environment transport pass needs at least 2 samples per pixel");
  if (settings.spp > SceneAccel::kMaxPacket)
    throw Error("the environment transport pass takes at most " + std::to_string(SceneAccel::kMaxPacket) + " samples per pixel");
  const SceneEnvironment& env = tracer.scene().environment;
  const Environment* map = env.as<Environment>();
  if (!map) throw Error("the light solve needs a lat-long environment");
  band_rows = std::max(1, band_rows);
  const int bands = (camera.height + band_rows - 1) / band_rows;
  const PixelFilterSampler filter(settings.filter);
  // What a recorder's constructor reads: the mesh count and the environment's size.
  SceneGradients like;
  like.mesh_base_colour.resize(tracer.scene().meshes.size());
  like.mesh_roughness.resize(tracer.scene().meshes.size());
  like.mesh_metallic.resize(tracer.scene().meshes.size());
  like.environment.resize(env->parameter_count());
  const int spp = settings.spp;

  tbb::parallel_for(0, bands, [&](int band) {
    if (control.cancel && control.cancel->load()) return;
    // One recorder per sample of a pixel: each logs its own path's lookups.
    std::vector<std::unique_ptr<GradientTile>> recorders;
    for (int s = 0; s < spp; ++s) {
      recorders.push_back(std::make_unique<GradientTile>(like, env));
      recorders.back()->log_environment_only();
    }
    Ray rays[SceneAccel::kMaxPacket];
    uint64_t pixel[SceneAccel::kMaxPacket], shadows[SceneAccel::kMaxPacket];
    uint32_t index[SceneAccel::kMaxPacket];
    Vec3 L[SceneAccel::kMaxPacket];
    float coverage[SceneAccel::kMaxPacket];
    PathAdjoint adjoint[SceneAccel::kMaxPacket];
    PathWalkWriter walks[SceneAccel::kMaxPacket];
    EnvTransportPixel out;
    const int y1 = std::min(camera.height, (band + 1) * band_rows);
    for (int y = band * band_rows; y < y1; ++y)
      for (int x = 0; x < camera.width; ++x) {
        // The pixel's samples: primal (radiance, shadow-ray outcomes, walks), then
        // the replay with a unit adjoint into one recorder per sample.
        for (int s = 0; s < spp; ++s) {
          index[s] = uint32_t(s);
          rays[s] = camera_sample(camera, filter, settings.seed, x, y, s, &pixel[s]);
        }
        tracer.sample_radiance_batch(rays, spp, pixel, index, settings, L, coverage, nullptr, shadows, walks);
        for (int s = 0; s < spp; ++s) {
          recorders[s]->clear();
          const PathWalkReader kept(walks[s].words.empty() ? nullptr : walks[s].words.data());
          adjoint[s] = PathAdjoint{L[s], Vec3(1.0f), recorders[s].get(), &shadows[s], kept};
        }
        tracer.sample_adjoint_batch(rays, spp, pixel, index, settings, adjoint);
        // Per half: mean radiance and coverage, lookups weighted by 1 / its samples.
        out.x = x;
        out.y = y;
        for (int h = 0; h < 2; ++h) {
          const int n = (spp - h + 1) / 2;  // even indices: ceil(spp / 2); odd: floor
          const float inv = 1.0f / float(n);
          out.L[h] = Vec3(0.0f);
          out.coverage[h] = 0.0f;
          out.lookups[h].clear();
          for (int s = h; s < spp; s += 2) {
            out.L[h] += L[s] * inv;
            out.coverage[h] += coverage[s] * inv;
            for (const GradientTile::EnvRecord& r : recorders[s]->environment_log())
              out.lookups[h].push_back(EnvLookup{uint32_t(map->texel_index(r.d)), r.d_Le * (inv * map->strength())});
          }
        }
        visit(band, out);
      }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
}

}  // namespace ptir
