#include "ptir/render/render_path.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <mutex>

#include "ptir/core/error.h"
#include "ptir/render/camera_sample.h"
#include "ptir/math/path_sampler.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/math/rng.h"
#include "ptir/render/tile_reduce.h"

namespace ptir {

namespace {

// Samples of a pixel traced together: their camera rays form one packet.
constexpr int kBatch = SceneAccel::kMaxPacket;

}  // namespace

Image render_path(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                  const RenderControl& control, PathStats* stats, ReplayCache* cache, bool transparent_film,
                  uint32_t first_sample) {
  if (settings.spp < 1) throw Error("samples per pixel must be at least 1");
  if (settings.max_bounces < 0) throw Error("bounces must be at least 0");
  const PixelFilterSampler filter(settings.filter);
  Image image(camera.width, camera.height, {"R", "G", "B", "A"});
  const size_t pixels = size_t(camera.width) * size_t(camera.height);
  std::vector<Vec3>* sample_radiance = cache && cache->keep_radiance ? &cache->radiance : nullptr;
  std::vector<uint64_t>* sample_shadows = cache && cache->keep_shadows ? &cache->shadows : nullptr;
  WalkStore* sample_walks = cache ? cache->walks : nullptr;
  if (cache) cache->radiance.clear(), cache->shadows.clear();
  if (sample_radiance) sample_radiance->assign(pixels * size_t(settings.spp), Vec3(0.0f));
  if (sample_shadows) sample_shadows->assign(pixels * size_t(settings.spp), 0u);
  if (sample_walks) sample_walks->reset(pixels * size_t(settings.spp));
  std::atomic<size_t> done{0};
  std::atomic<uint64_t> paths{0}, vertices{0}, shadow_rays{0};
  std::mutex progress_mutex;
  const int group = std::max(1, kBatch / settings.spp);  // pixels whose samples fill one batch

  tbb::parallel_for(tbb::blocked_range2d<int>(0, camera.height, 8, 0, camera.width, 8), [&](const tbb::blocked_range2d<int>& r) {
    if (control.cancel && control.cancel->load()) return;
    PathStats local;
    for (int y = r.rows().begin(); y < r.rows().end(); ++y)
      for (int x = r.cols().begin(); x < r.cols().end(); x += group) {
        // The samples of `gx` neighbouring pixels (consecutive in the sample layout) in
        // batches, their camera rays traced together (PathTracer::sample_radiance_batch).
        const int gx = std::min(group, r.cols().end() - x), total = gx * settings.spp;
        Vec3 sum[kBatch];
        float covered[kBatch] = {};
        for (int s0 = 0; s0 < total; s0 += kBatch) {
          // Cancellation within a pixel too: at high sample counts one tile can take minutes.
          if (s0 > 0 && control.cancel && control.cancel->load(std::memory_order_relaxed)) return;
          const int n = std::min(kBatch, total - s0);
          Ray rays[kBatch];
          uint64_t pixel[kBatch];
          uint32_t index[kBatch];
          Vec3 L[kBatch];
          float c[kBatch];
          for (int j = 0; j < n; ++j) {
            index[j] = first_sample + uint32_t((s0 + j) % settings.spp);
            rays[j] = camera_sample(camera, filter, settings.seed, x + (s0 + j) / settings.spp, y, int(index[j]), &pixel[j]);
          }
          const size_t at = (size_t(y) * camera.width + x) * settings.spp + s0;
          thread_local PathWalkWriter walks[kBatch];
          tracer.sample_radiance_batch(rays, n, pixel, index, settings, L, c, &local,
                                       sample_shadows ? &(*sample_shadows)[at] : nullptr, sample_walks ? walks : nullptr);
          if (sample_walks)
            for (int j = 0; j < n; ++j) sample_walks->keep(at + j, walks[j]);
          for (int j = 0; j < n; ++j) {
            const int p = (s0 + j) / settings.spp;
            if (sample_radiance) (*sample_radiance)[at + j] = L[j];
            if (!transparent_film || c[j] > 0.0f) sum[p] += L[j];
            covered[p] += c[j];
          }
        }
        float inv = 1.0f / float(settings.spp);
        for (int p = 0; p < gx; ++p) {
          image.at(x + p, y, 0) = sum[p].x * inv;
          image.at(x + p, y, 1) = sum[p].y * inv;
          image.at(x + p, y, 2) = sum[p].z * inv;
          image.at(x + p, y, 3) = covered[p] * inv;
        }
      }
    paths += local.paths;
    vertices += local.vertices;
    shadow_rays += local.shadow_rays;
    size_t now = done.fetch_add(r.rows().size() * r.cols().size()) + r.rows().size() * r.cols().size();
    if (control.progress) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      control.progress(float(now) / float(pixels));
    }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
  if (stats) {
    stats->paths += paths;
    stats->vertices += vertices;
    stats->shadow_rays += shadow_rays;
  }
  return image;
}

void set_film_alpha(Image& rgba, bool transparent_film, bool environment_seen) {
  if (transparent_film || !environment_seen || rgba.channels < 4) return;
  for (size_t p = 0, n = size_t(rgba.width) * rgba.height; p < n; ++p) rgba.pixels[p * rgba.channels + 3] = 1.0f;
}

void render_path_backward(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                          const Image& d_image, SceneGradients& grads, const RenderControl& control,
                          const ReplayCache* cache, TileReduceStats* tile_stats) {
  // Roulette's survival probability depends on the materials through beta: its
  // 1 / q has a derivative the replay (every sampling decision held fixed) omits.
  if (settings.russian_roulette)
    throw Error("path replay needs Russian roulette off (IntegratorSettings::russian_roulette = false, as the "
                "inversion's integrator has it): its survival probability depends on the materials");
  if (d_image.width != camera.width || d_image.height != camera.height || d_image.channels < 3)
    throw Error("image adjoint must be " + std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                " with at least 3 channels");
  // The cache's parts (null: not kept).
  const std::vector<Vec3>* sample_radiance = cache && !cache->radiance.empty() ? &cache->radiance : nullptr;
  const std::vector<uint64_t>* sample_shadows = cache && !cache->shadows.empty() ? &cache->shadows : nullptr;
  const WalkStore* sample_walks = cache ? cache->walks : nullptr;
  if (sample_radiance && sample_radiance->size() != size_t(camera.width) * camera.height * settings.spp)
    throw Error("stored sample radiance does not match the camera and sample count");
  if (sample_shadows && sample_shadows->size() != size_t(camera.width) * camera.height * settings.spp)
    throw Error("stored shadow-ray outcomes do not match the camera and sample count");
  if (sample_walks && sample_walks->size() != size_t(camera.width) * camera.height * settings.spp)
    throw Error("stored walks do not match the camera and sample count");
  const PixelFilterSampler filter(settings.filter);
  const float inv_spp = 1.0f / float(settings.spp);
  reduce_gradient_tiles(camera.width, camera.height, tracer.scene().environment, grads, control,
                        [&](const PixelTile& tile, GradientTile& g) {
    // The samples of neighbouring pixels with a non-zero adjoint in batches of
    // whole pixels where they fit (their camera rays traced together), pixel by
    // pixel, sample by sample: the adds into the tile come in the order of a
    // pixel-by-pixel loop.
    Ray rays[kBatch];
    uint64_t pixel[kBatch];
    uint32_t index[kBatch];
    PathAdjoint adjoint[kBatch];
    int n = 0;
    auto flush = [&] {
      tracer.sample_adjoint_batch(rays, n, pixel, index, settings, adjoint);
      n = 0;
    };
    for (int y = tile.y0; y < tile.y1; ++y)
      for (int x = tile.x0; x < tile.x1; ++x) {
        Vec3 dI(d_image.at(x, y, 0), d_image.at(x, y, 1), d_image.at(x, y, 2));
        if (dI.x == 0.0f && dI.y == 0.0f && dI.z == 0.0f) continue;
        if (n + settings.spp > kBatch && n > 0) flush();
        for (int s = 0; s < settings.spp; ++s) {
          if (n == kBatch) flush();
          index[n] = uint32_t(s);
          rays[n] = camera_sample(camera, filter, settings.seed, x, y, s, &pixel[n]);
          // Primal radiance of this sample (stored or recomputed), then its replay (pixel = mean of samples).
          const size_t at = (size_t(y) * camera.width + x) * settings.spp + s;
          Vec3 L = sample_radiance ? (*sample_radiance)[at] : tracer.sample_radiance(rays[n], pixel[n], index[n], settings);
          adjoint[n] = PathAdjoint{L, dI * inv_spp, &g, sample_shadows ? &(*sample_shadows)[at] : nullptr,
                                   sample_walks ? sample_walks->path(at) : PathWalkReader()};
          ++n;
        }
      }
    if (n > 0) flush();
  }, tile_stats);
}

}  // namespace ptir
