#include "ptir/optim/albedo_demodulation.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "ptir/math/rng.h"
#include "ptir/math/sampling.h"

namespace ptir {

namespace {
constexpr float kSelfRange = 8.0f;  // IntegratorSettings::self_range_scale's default
}  // namespace

std::vector<Vec3> demodulated_albedo(const SceneAccel& accel, const std::vector<Vec3>& radiance,
                                     const SceneEnvironment& environment, const DemodulationSettings& s) {
  const GaussianField& f = accel.field();
  const size_t n = f.size();
  std::vector<Vec3> albedo(n, Vec3(0.0f));
  if (radiance.size() != n) return albedo;
  const float min_t = accel.settings().cull.min_transmittance;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i < range.end(); ++i) {
      const Vec3 nrm = normalize(f.normal[i]);
      const Frame frame(nrm);
      // The path tracer's self-intersection rule (scattering.cpp, backface-aware): a ray leaving
      // the surface skips the back-facing splats within kSelfRange x the Gaussian's size, and
      // the Gaussian itself.
      const float range = kSelfRange * std::max({f.scale[i].x, f.scale[i].y, f.scale[i].z});
      const Vec3 origin = f.position[i];
      const uint32_t self = uint32_t(i);
      Vec3 d;  // the ray's direction, read by the test
      auto is_self = [&](const GaussianHit& h) {
        if (h.id == self) return true;
        if (!(h.t > 0.0f && h.t <= range)) return false;
        const Vec3 nj = f.normal[h.id];
        const float c = dot(d, nj);
        return (f.normals_from_file || dot(nj, nrm) >= 0.0f ? c : -c) > 0.0f;
      };
      const HitTest skip = hit_test(is_self);
      const Rng rng(s.seed, uint64_t(i));
      Vec3 sum(0.0f);
      for (int k = 0; k < s.rays; ++k) {
        // A cosine-distributed direction: the mean of L_in over them is E / pi.
        d = normalize(frame.to_world(square_to_cosine_hemisphere(rng.at(2 * uint64_t(k)), rng.at(2 * uint64_t(k) + 1))));
        Ray ray{origin, d};
        Vec3 field_part(0.0f);
        float T = 1.0f;
        const WalkEnd end = accel.walk(
            ray,
            [&](const GaussianHit& h) {
              field_part += (T * h.alpha) * radiance[h.id];  // composited like the preview, in linear radiance
              T *= 1.0f - h.alpha;
              return T > min_t;
            },
            nullptr, true, &skip);
        // A mesh ends the walk: its radiance is unknown here, taken as black (an occluder).
        sum += field_part + (end.mesh.valid ? Vec3(0.0f) : T * environment.eval(ray.d));
      }
      const Vec3 e = sum / float(std::max(1, s.rays));  // E / pi
      for (int c = 0; c < 3; ++c)
        albedo[i][c] = std::clamp(e[c] > 1e-6f ? radiance[i][c] / e[c] : s.max_albedo, s.min_albedo, s.max_albedo);
    }
  });
  return albedo;
}

}  // namespace ptir
