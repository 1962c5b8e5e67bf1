#include "ptir/render/render_path.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <mutex>

#include "ptir/core/error.h"
#include "ptir/math/rng.h"

namespace ptir {

Image render_path(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                  const RenderControl& control, PathStats* stats) {
  if (settings.spp < 1) throw Error("samples per pixel must be at least 1");
  if (settings.max_bounces < 0) throw Error("bounces must be at least 0");
  Image image(camera.width, camera.height, {"R", "G", "B", "A"});
  const size_t pixels = size_t(camera.width) * size_t(camera.height);
  std::atomic<size_t> done{0};
  std::atomic<uint64_t> paths{0}, vertices{0}, shadow_rays{0};
  std::mutex progress_mutex;

  tbb::parallel_for(tbb::blocked_range2d<int>(0, camera.height, 8, 0, camera.width, 8), [&](const tbb::blocked_range2d<int>& r) {
    if (control.cancel && control.cancel->load()) return;
    PathStats local;
    for (int y = r.rows().begin(); y < r.rows().end(); ++y)
      for (int x = r.cols().begin(); x < r.cols().end(); ++x) {
        const uint64_t pixel = uint64_t(y) * uint64_t(camera.width) + uint64_t(x);
        Vec3 sum(0.0f);
        float covered = 0.0f;
        for (int s = 0; s < settings.spp; ++s) {
          // Jitter within the pixel, keyed on (seed, pixel, sample) like the path itself.
          Rng jitter(hash_combine(hash_combine(settings.seed, pixel), uint64_t(s)), 0, 0);
          Ray ray = camera.generate_ray(float(x) + jitter.at(0), float(y) + jitter.at(1));
          float c = 0.0f;
          sum += tracer.sample_radiance(ray, pixel, uint32_t(s), settings, &c, &local);
          covered += c;
        }
        float inv = 1.0f / float(settings.spp);
        image.at(x, y, 0) = sum.x * inv;
        image.at(x, y, 1) = sum.y * inv;
        image.at(x, y, 2) = sum.z * inv;
        image.at(x, y, 3) = covered * inv;
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

}  // namespace ptir
