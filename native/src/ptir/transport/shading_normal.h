// The shading-normal correction of an interpolated (smooth) normal, as Cycles does
// it (ensure_valid_reflection in its kernel, applied to every BSDF's normal): where
// the mirror reflection of the view about the shading normal N would fall below
// the face (Ng), N is tilted toward Ng, in the plane of N and Ng, just enough that
// the reflection leaves the face at least as steeply as the view arrived (cos >=
// min(0.9 Ng.I, 0.01)). Without it a view grazing a smooth silhouette sees a
// normal facing away and the surface turns black there.
#pragma once

#include <algorithm>
#include <cmath>

#include "ptir/math/vec.h"

namespace ptir {

// Ng: unit face normal, I: unit direction toward the viewer, both on the same side
// (Ng.I >= 0); N: unit shading normal on Ng's side. Returns the corrected unit normal.
inline Vec3 valid_reflection_normal(Vec3 Ng, Vec3 I, Vec3 N) {
  const Vec3 R = 2.0f * dot(N, I) * N - I;
  // Reflections may always be at least as shallow as the incoming ray.
  const float threshold = std::min(0.9f * dot(Ng, I), 0.01f);
  if (dot(Ng, R) >= threshold) return N;
  // Frame with Ng as z and N in the x-z plane; solve for the tilt of N whose
  // reflection of I meets the threshold (a quadratic in N.z^2).
  const float NdotNg = dot(N, Ng);
  const Vec3 X = normalize(N - NdotNg * Ng);
  const float Ix = dot(I, X), Iz = dot(I, Ng);
  const float Ix2 = Ix * Ix, Iz2 = Iz * Iz;
  const float a = Ix2 + Iz2;
  const float b = std::sqrt(std::max(0.0f, Ix2 * (a - threshold * threshold)));
  const float c = Iz * threshold + a;
  const float fac = 0.5f / a;
  const float N1_z2 = fac * (b + c), N2_z2 = fac * (-b + c);
  bool valid1 = N1_z2 > 1e-5f && N1_z2 <= 1.0f + 1e-5f;
  bool valid2 = N2_z2 > 1e-5f && N2_z2 <= 1.0f + 1e-5f;
  const auto root = [](float z2) { return std::sqrt(std::max(0.0f, z2)); };
  float nx, nz;
  if (valid1 && valid2) {
    // Both tilts work: the one whose reflection is shallower (closer to N), unless only one reflects upward.
    const float N1x = root(1.0f - N1_z2), N1z = root(N1_z2), N2x = root(1.0f - N2_z2), N2z = root(N2_z2);
    const float R1 = 2.0f * (N1x * Ix + N1z * Iz) * N1z - Iz;
    const float R2 = 2.0f * (N2x * Ix + N2z * Iz) * N2z - Iz;
    valid1 = R1 >= 1e-5f;
    valid2 = R2 >= 1e-5f;
    const bool first = valid1 && valid2 ? R1 < R2 : R1 > R2;
    nx = first ? N1x : N2x;
    nz = first ? N1z : N2z;
  } else if (valid1 || valid2) {
    const float z2 = valid1 ? N1_z2 : N2_z2;
    nx = root(1.0f - z2);
    nz = root(z2);
  } else {
    return Ng;
  }
  return normalize(nx * X + nz * Ng);
}

}  // namespace ptir
