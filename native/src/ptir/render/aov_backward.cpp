#include "ptir/render/aov_backward.h"

#include "ptir/core/error.h"
#include "ptir/render/tile_reduce.h"

namespace ptir {

namespace {

void check_size(const Image* img, const Camera& camera, int channels, const char* what) {
  if (img && (img->width != camera.width || img->height != camera.height || img->channels < channels))
    throw Error(std::string(what) + " adjoint must be " + std::to_string(camera.width) + "x" +
                std::to_string(camera.height) + " with at least " + std::to_string(channels) + " channel(s)");
}

}  // namespace

void render_aov_backward(const SceneAccel& accel, const Camera& camera, const AovSettings& settings,
                         const Image* d_albedo, const Image* d_roughness, SceneGradients& grads,
                         const MaterialMapWalks* walks) {
  check_size(d_albedo, camera, 3, "albedo");
  check_size(d_roughness, camera, 1, "roughness");
  if (walks && (walks->width != camera.width || walks->height != camera.height))
    throw Error("the material maps' kept walks are for another image size");
  const GaussianField& field = accel.field();
  const SceneEnvironment no_environment;  // material maps have no environment adjoint
  reduce_gradient_tiles(camera.width, camera.height, no_environment, grads, {}, [&](const PixelTile& tile, GradientTile& g) {
    thread_local std::vector<WeightedHit> hits;
    for (int y = tile.y0; y < tile.y1; ++y)
      for (int x = tile.x0; x < tile.x1; ++x) {
        Vec3 dA = d_albedo ? Vec3(d_albedo->at(x, y, 0), d_albedo->at(x, y, 1), d_albedo->at(x, y, 2)) : Vec3(0.0f);
        float dR = d_roughness ? d_roughness->at(x, y, 0) : 0.0f;
        if (dA.x == 0.0f && dA.y == 0.0f && dA.z == 0.0f && dR == 0.0f) continue;
        // The same primary ray and interaction as render_aov with one sample.
        Ray ray = camera.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
        Rng rng(settings.seed, camera.full_pixel_index(x, y), 0);
        hits.clear();
        InteractionBuilder builder(field, settings.interaction, accel.settings().cull.min_transmittance, ray.d, rng.key(),
                                   &hits);
        // The forward's walk handed over again (kept), or walked again; the mesh
        // only where it ended the walk.
        int32_t mesh = -1;
        if (walks) {
          const MaterialMapWalks::Pixel& px = walks->pixel(x, y);
          const GaussianHit* kept = walks->hits(x, y);
          for (uint32_t i = 0; i < px.count; ++i) builder.add(kept[i]);
          mesh = px.mesh;
        } else {
          WalkEnd end = accel.walk(ray, [&](const GaussianHit& h) { return builder.add(h); }, nullptr, true);
          if (!end.stopped && end.mesh.valid) mesh = int32_t(end.mesh.mesh);
        }
        SurfaceInteraction si = builder.finish(ray);
        if (si.valid) {
          if (settings.interaction.mode == InteractionMode::Discrete) {
            g.add_gaussian(uint32_t(si.picked), dA, dR, 0.0f);
            continue;
          }
          for (const WeightedHit& h : hits) {
            float w = h.weight / si.opacity;
            g.add_gaussian(uint32_t(h.id), w * dA, w * dR, 0.0f);
          }
        } else if (mesh >= 0) {
          g.add_mesh(uint32_t(mesh), dA, dR, 0.0f);
        }
      }
  });
}

}  // namespace ptir
