// The response of one Gaussian along a ray (docs/method.md §2), and the culling rule
// that decides which Gaussians count as hits.
//
// Everything is evaluated in the Gaussian's unit space, where it is the standard
// normal: o' = S^-1 R^T (o - mu), d' = S^-1 R^T d. Along the ray the squared
// Mahalanobis distance is smallest at t_peak = -o'.d' / d'.d', where it equals
// D^2 = |d' x o'|^2 / |d'|^2 (the cross-product form stays accurate far from mu).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

#include "ptir/math/vec.h"

namespace ptir {

// Culling constants of 3dgrut / PTIR (docs/method.md §2).
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

// t_peak and D^2 of Gaussian g along the ray o + t d, in two steps: the origin
// in unit space, o' = S^-1 R^T (o - mu), then the peak along d.
//
// Written once for F = float (single rays, the reference) and for F = a GCC
// vector of floats holding one ray per lane (packets; O = float when the lanes
// share their origin, as camera rays do): every caller runs the same IEEE
// operations in the same order, so the traversal and the reference agree bit for
// bit. (No FMA contraction: the engine layers are compiled with -ffp-contract=off.)
template <class F>
inline void unit_origin(const GaussianTraceData& g, F ox, F oy, F oz, F& oux, F& ouy, F& ouz) {
  const auto& m = g.to_unit.m;
  F px = ox - g.mu.x, py = oy - g.mu.y, pz = oz - g.mu.z;
  oux = m[0][0] * px + m[0][1] * py + m[0][2] * pz;
  ouy = m[1][0] * px + m[1][1] * py + m[1][2] * pz;
  ouz = m[2][0] * px + m[2][1] * py + m[2][2] * pz;
}

// The parts of the peak before the division: |d'|^2, o'.d' and |d' x o'|^2.
template <class F, class O>
inline void peak_parts(const GaussianTraceData& g, O oux, O ouy, O ouz, F dx, F dy, F dz, F& dd, F& od, F& cc) {
  const auto& m = g.to_unit.m;
  // d' = S^-1 R^T d.
  F dux = m[0][0] * dx + m[0][1] * dy + m[0][2] * dz;
  F duy = m[1][0] * dx + m[1][1] * dy + m[1][2] * dz;
  F duz = m[2][0] * dx + m[2][1] * dy + m[2][2] * dz;
  dd = dux * dux + duy * duy + duz * duz;
  od = dux * oux + duy * ouy + duz * ouz;
  F cx = duy * ouz - duz * ouy, cy = duz * oux - dux * ouz, cz = dux * ouy - duy * oux;
  cc = cx * cx + cy * cy + cz * cz;
}

// t_peak = -o'.d' / |d'|^2; D^2 = |d' x o'|^2 / |d'|^2 (one division).
template <class F>
inline void peak_from_parts(F dd, F od, F cc, F& t, F& d2) {
  F inv_dd = 1.0f / dd;
  t = -od * inv_dd;
  d2 = cc * inv_dd;
}

template <class F, class O>
inline void peak_from_unit_origin(const GaussianTraceData& g, O oux, O ouy, O ouz, F dx, F dy, F dz, F& t, F& d2) {
  F dd, od, cc;
  peak_parts(g, oux, ouy, ouz, dx, dy, dz, dd, od, cc);
  peak_from_parts(dd, od, cc, t, d2);
}

// Whether D^2 = cc / dd surely exceeds the accepted accept_d2, decided without the
// division: the division's rounding moves D^2 by under 2^-23 of itself, far less
// than the 1e-5 margin, so whatever this rejects the exact test rejects too (and
// NaN, zero or overflowing parts are left to the exact test). For single rays,
// whose candidates are half outside the accepted region.
inline bool surely_outside(float dd, float cc, float accept_d2) { return cc > accept_d2 * dd * 1.00001f; }

template <class F>
inline void peak_t_d2(const GaussianTraceData& g, F ox, F oy, F oz, F dx, F dy, F dz, F& t, F& d2) {
  F oux, ouy, ouz;
  unit_origin(g, ox, oy, oz, oux, ouy, ouz);
  peak_from_unit_origin(g, oux, ouy, ouz, dx, dy, dz, t, d2);
}

// The few non-arithmetic steps of exp_nonpositive, for a float and for a GCC
// vector of floats (for which x < x is the matching vector of ints).
inline float max_with(float x, float lo) { return x > lo ? x : lo; }
inline float min_with(float x, float hi) { return x < hi ? x : hi; }
inline float floor_positive(float x) { return float(int32_t(x)); }
inline float pow2_neg(float m) {  // 2^-m, m an integer in [0, 126]
  int32_t bits = (127 - int32_t(m)) << 23;
  float s;
  std::memcpy(&s, &bits, sizeof s);
  return s;
}
template <class F>
inline F max_with(F x, float lo) { return x > lo ? x : F{} + lo; }
template <class F>
inline F min_with(F x, float hi) { return x < hi ? x : F{} + hi; }
template <class F>
inline F floor_positive(F x) { return __builtin_convertvector(__builtin_convertvector(x, decltype(x < x)), F); }
template <class F>
inline F pow2_neg(F m) { return (F)((127 - __builtin_convertvector(m, decltype(m < m))) << 23); }

// exp(x) for x <= 0 within 1.5 ulp (Cephes' expf scheme), written once for floats
// and GCC vectors: the traversal evaluates it for whole packets, and every caller
// gets the same bits. Below -87 it returns exp(-87) (~1.6e-38).
template <class F>
inline F exp_nonpositive(F x) {
  x = max_with(x, -87.0f);
  // x = -m ln2 + r with |r| <= ln2/2; ln2 in two parts so that r is exact.
  F m = floor_positive(0.5f - x * 1.44269504f);
  F r = x + m * 0.693359375f + m * -2.12194440e-4f;
  // exp(r) by a minimax polynomial, then times 2^-m.
  F p = r * 1.9875691500e-4f + 1.3981999507e-3f;
  p = p * r + 8.3334519073e-3f;
  p = p * r + 4.1665795894e-2f;
  p = p * r + 1.6666665459e-1f;
  p = p * r + 5.0000001201e-1f;
  p = p * r * r + r + 1.0f;
  return p * pow2_neg(m);
}

inline PeakResponse peak_response(const GaussianTraceData& g, Vec3 o, Vec3 d) {
  PeakResponse p;
  peak_t_d2(g, o.x, o.y, o.z, d.x, d.y, d.z, p.t, p.d2);
  p.response = exp_nonpositive(-0.5f * p.d2);
  return p;
}

// Squared unit-space radius of the region where a Gaussian of opacity sigma can be
// accepted: rho >= min_response and sigma*rho >= min_alpha, i.e.
// D^2 <= min(2 ln(1/min_response), 2 ln(sigma/min_alpha)). Negative: never a hit.
//
// Note (docs/method.md §2): the authors' code bounds the proxy by sigma*rho =
// min_response, which is smaller than the region the cull rule admits; a proxy
// smaller than the accepted region would make the hit set depend on the BVH. We
// bound exactly the accepted region, so traversal and a brute-force reference
// agree hit for hit.
inline float accept_radius_sq(float sigma, const CullSettings& cull) {
  if (!(sigma > 0.0f)) return -1.0f;
  float r_response = -2.0f * std::log(cull.min_response);
  float r_alpha = 2.0f * std::log(sigma / cull.min_alpha);
  return std::min(r_response, r_alpha);
}

// Alpha sigma * rho of an accepted hit at squared distance d2, clamped to max_alpha
// (for a float or a GCC vector of lanes).
template <class F>
inline F accepted_alpha(F d2, float sigma, const CullSettings& cull) {
  return min_with(sigma * exp_nonpositive(-0.5f * d2), cull.max_alpha);
}

// Alpha of a hit at squared distance d2, or 0 when culled. The test on D^2 is the
// cull rule (rho >= min_response and sigma rho >= min_alpha) in closed form, and
// lets the traversal reject a candidate before evaluating exp.
inline float hit_alpha(float d2, float sigma, float accept_d2, const CullSettings& cull) {
  if (!(d2 <= accept_d2)) return 0.0f;
  return accepted_alpha(d2, sigma, cull);
}

inline float hit_alpha(const PeakResponse& p, float sigma, const CullSettings& cull) {
  return hit_alpha(p.d2, sigma, accept_radius_sq(sigma, cull), cull);
}

}  // namespace ptir
