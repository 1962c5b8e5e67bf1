// Directions the BSDF tests share (local frame, z = normal).
#pragma once

#include <algorithm>
#include <cmath>

#include "ptir/math/rng.h"
#include "ptir/math/sampling.h"

namespace ptir::test {

// The direction at polar angle theta_deg (degrees) and azimuth phi.
inline Vec3 dir_at(float theta_deg, float phi = 0.3f) {
  float t = theta_deg * kPi / 180.0f;
  return spherical_direction(std::sin(t), std::cos(t), phi);
}

// Random upper-hemisphere direction with cos theta in [z_min, 1], uniform in cos.
inline Vec3 random_dir(Rng& rng, float z_min = 0.0f) {
  float z = z_min + (1.0f - z_min) * rng.next();
  float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  float phi = 2 * kPi * rng.next();
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace ptir::test
