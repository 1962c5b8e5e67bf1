// The response of one Gaussian along a ray (METHOD §2), and the culling rule
// that decides which Gaussians count as hits.
//
// Everything is evaluated in the Gaussian's unit space, where it is the standard
// normal: o' = S^-1 R^T (o - mu), d' = S^-1 R^T d. Along the ray the squared
// Mahalanobis distance is smallest at t_peak = -o'.d' / d'.d', where it equals
// D^2 = |d' x o'|^2 / |d'|^2 (the cross-product form stays accurate far from mu).
#pragma once

#include <cmath>
#include <cstdint>

#include "ptir/math/vec.h"

namespace ptir {

// Culling constants of 3dgrut / PTIR (METHOD §2).
struct CullSettings {
  float min_response = 0.0113f;        // rho below this is ignored
  float min_alpha = 1.0f / 255.0f;     // alpha below this is ignored
  float max_alpha = 0.99f;             // alpha is clamped to this
  float min_transmittance = 0.001f;    // compositing stops below this
};

// Per-Gaussian data the traversal touches, packed into one cache line.
struct alignas(64) GaussianTraceData {
  Vec3 mu;
  float opacity;
  Mat3 to_unit;      // S^-1 R^T: world offset -> unit space
  float accept_d2;   // accept_radius_sq(opacity): hits need D^2 <= this (< 0: never)
  uint32_t id;       // index of the Gaussian in the field
};

struct PeakResponse {
  float t;         // ray parameter of the response peak
  float d2;        // squared Mahalanobis distance at the peak
  float response;  // rho = exp(-d2 / 2)
};

// The ray in a Gaussian's unit space.
struct UnitRay {
  Vec3 ou, du;
  float dd;  // |du|^2
};

inline UnitRay to_unit_ray(const GaussianTraceData& g, Vec3 o, Vec3 d) {
  UnitRay u;
  u.ou = g.to_unit * (o - g.mu);
  u.du = g.to_unit * d;
  u.dd = dot(u.du, u.du);
  return u;
}
inline float peak_t(const UnitRay& u) { return -dot(u.ou, u.du) / u.dd; }
inline float peak_d2(const UnitRay& u) { return length_sq(cross(u.du, u.ou)) / u.dd; }

inline PeakResponse peak_response(const GaussianTraceData& g, Vec3 o, Vec3 d) {
  UnitRay u = to_unit_ray(g, o, d);
  PeakResponse p;
  p.t = peak_t(u);
  p.d2 = peak_d2(u);
  p.response = std::exp(-0.5f * p.d2);
  return p;
}

// Squared unit-space radius of the region where a Gaussian of opacity sigma can be
// accepted: rho >= min_response and sigma*rho >= min_alpha, i.e.
// D^2 <= min(2 ln(1/min_response), 2 ln(sigma/min_alpha)). Negative: never a hit.
//
// Note: METHOD §2 bounds the proxy by sigma*rho = min_response, which is smaller
// than the region the cull rule admits; a proxy smaller than the accepted region
// would make the hit set depend on the BVH. We bound exactly the accepted region,
// so traversal and a brute-force reference agree hit for hit.
inline float accept_radius_sq(float sigma, const CullSettings& cull) {
  if (!(sigma > 0.0f)) return -1.0f;
  float r_response = -2.0f * std::log(cull.min_response);
  float r_alpha = 2.0f * std::log(sigma / cull.min_alpha);
  return std::min(r_response, r_alpha);
}

// Alpha of a hit at squared distance d2, or 0 when culled. The test on D^2 is the
// cull rule (rho >= min_response and sigma rho >= min_alpha) in closed form, and
// lets the traversal reject a candidate before evaluating exp.
inline float hit_alpha(float d2, float sigma, float accept_d2, const CullSettings& cull) {
  if (!(d2 <= accept_d2)) return 0.0f;
  return std::min(cull.max_alpha, sigma * std::exp(-0.5f * d2));
}

inline float hit_alpha(const PeakResponse& p, float sigma, const CullSettings& cull) {
  return hit_alpha(p.d2, sigma, accept_radius_sq(sigma, cull), cull);
}

}  // namespace ptir
