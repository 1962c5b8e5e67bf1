#include "ptir/transport/orient_normals.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <cmath>

namespace ptir {

namespace {
// Hits vote only while the ray is still mostly transparent (the first surface).
constexpr float kVisibleTransmittance = 0.5f;
}  // namespace

OrientStats orient_normals_to_cameras(GaussianField& field, const SceneAccel& accel, const std::vector<Camera>& cameras,
                                      int rays_per_camera, bool keep_unseen) {
  OrientStats stats;
  if (field.normals_from_file || field.size() == 0) return stats;
  const size_t n = field.size();
  const float min_T = accel.settings().cull.min_transmittance;
  tbb::enumerable_thread_specific<std::vector<float>> votes_tls([n] { return std::vector<float>(n, 0.0f); });

  for (const Camera& cam : cameras) {
    // Subsample the pixel grid so each camera costs about rays_per_camera rays.
    double pixels = double(cam.width) * double(cam.height);
    int stride = std::max(1, int(std::floor(std::sqrt(pixels / std::max(1, rays_per_camera)))));
    int rows = (cam.height + stride - 1) / stride, cols = (cam.width + stride - 1) / stride;
    tbb::parallel_for(0, rows, [&](int ry) {
      std::vector<float>& votes = votes_tls.local();
      for (int rx = 0; rx < cols; ++rx) {
        Ray ray = cam.generate_ray((rx + 0.5f) * stride, (ry + 0.5f) * stride);
        float T = 1.0f;
        // Each hit of the first surface votes with its compositing weight for the
        // side facing the camera. Hits behind it (T <= 0.5) belong to surfaces the
        // camera sees through another one and do not vote: they would face inward.
        accel.walk(ray, [&](const GaussianHit& h) {
          float w = T * h.alpha;
          if (T > kVisibleTransmittance) votes[h.id] += dot(field.normal[h.id], ray.d) < 0.0f ? w : -w;
          T *= 1.0f - h.alpha;
          return T > kVisibleTransmittance && T >= min_T;
        }, nullptr, /*stop_when_opaque=*/true);
      }
    });
  }

  std::vector<float> votes(n, 0.0f);
  for (const auto& local : votes_tls)
    for (size_t i = 0; i < n; ++i) votes[i] += local[i];
  std::vector<uint8_t> unseen(n, 0);
  for (size_t i = 0; i < n; ++i) {
    if (votes[i] < 0.0f) {
      field.normal[i] = -field.normal[i];
      stats.flipped++;
    } else if (votes[i] == 0.0f) {
      unseen[i] = 1;
      stats.unseen++;
    }
  }
  if (stats.unseen > 0 && !keep_unseen) orient_normals_away_from_centroid(field, &unseen);
  return stats;
}

OrientStats orient_scene_normals(Scene& scene) {
  GaussianField& field = *scene.gaussians;
  OrientStats stats;
  if (field.normals_from_file || field.size() == 0) return stats;
  if (scene.cameras.empty()) {
    orient_normals_away_from_centroid(field);
    stats.unseen = field.size();
    return stats;
  }
  SceneAccel accel(field, scene.meshes);
  int rays_per_camera = std::max(4096, int(262144 / std::max<size_t>(1, scene.cameras.size())));
  return orient_normals_to_cameras(field, accel, scene.cameras, rays_per_camera);
}

}  // namespace ptir
