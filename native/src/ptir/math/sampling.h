// Warping functions from [0,1)^2 to directions, their densities, GGX microfacet
// normal sampling, and MIS heuristics. Header-only: everything here is small and
// sits on the hot path of the path tracer.
//
// Conventions (pbrt-v4 / Mitsuba 3): directions live in a local shading frame
// with z = the normal, are unit length, and point away from the surface. Every
// density is with respect to solid angle. Every sampler has a matching *_pdf that
// returns exactly the density the sampler draws from.
#pragma once

#include <algorithm>
#include <cmath>

#include "ptir/math/vec.h"

namespace ptir {

constexpr float kInv2Pi = 0.15915494309189533577f;
constexpr float kInv4Pi = 0.07957747154594766788f;

// ---------------------------------------------------------------------------
// Spherical-coordinate helpers (local frame, z = normal).

inline float safe_sqrt(float x) { return std::sqrt(std::max(x, 0.0f)); }
inline float cos_theta(Vec3 w) { return w.z; }
inline float cos2_theta(Vec3 w) { return w.z * w.z; }
inline float sin2_theta(Vec3 w) { return std::max(0.0f, 1.0f - w.z * w.z); }
inline float sin_theta(Vec3 w) { return std::sqrt(sin2_theta(w)); }
// Direction with polar angle theta (given by sin/cos) and azimuth phi.
inline Vec3 spherical_direction(float sin_t, float cos_t, float phi) {
  return {std::clamp(sin_t, -1.0f, 1.0f) * std::cos(phi), std::clamp(sin_t, -1.0f, 1.0f) * std::sin(phi),
          std::clamp(cos_t, -1.0f, 1.0f)};
}
// Polar angle in [0, pi].
inline float spherical_theta(Vec3 v) { return std::acos(std::clamp(v.z, -1.0f, 1.0f)); }
// Azimuth in [0, 2 pi).
inline float spherical_phi(Vec3 v) {
  float p = std::atan2(v.y, v.x);
  return p < 0 ? p + 2 * kPi : p;
}
// Mirror reflection of wo about the unit vector n (both pointing away).
inline Vec3 reflect(Vec3 wo, Vec3 n) { return 2.0f * dot(wo, n) * n - wo; }

// ---------------------------------------------------------------------------
// Disk, hemisphere, sphere.

// Shirley-Chiu concentric map of the square onto the unit disk (low distortion).
inline void square_to_concentric_disk(float u1, float u2, float& x, float& y) {
  float ox = 2.0f * u1 - 1.0f, oy = 2.0f * u2 - 1.0f;
  if (ox == 0.0f && oy == 0.0f) { x = y = 0.0f; return; }
  float r, theta;
  if (std::fabs(ox) > std::fabs(oy)) {
    r = ox;
    theta = 0.25f * kPi * (oy / ox);
  } else {
    r = oy;
    theta = 0.5f * kPi - 0.25f * kPi * (ox / oy);
  }
  x = r * std::cos(theta);
  y = r * std::sin(theta);
}

// Cosine-weighted hemisphere (Malley's method): pdf = cos(theta) / pi.
inline Vec3 square_to_cosine_hemisphere(float u1, float u2) {
  float x, y;
  square_to_concentric_disk(u1, u2, x, y);
  return {x, y, safe_sqrt(1.0f - x * x - y * y)};
}
inline float cosine_hemisphere_pdf(float cos_t) { return cos_t > 0.0f ? cos_t * kInvPi : 0.0f; }

// Uniform sphere: pdf = 1 / (4 pi).
inline Vec3 square_to_uniform_sphere(float u1, float u2) {
  float z = 1.0f - 2.0f * u1;
  float r = safe_sqrt(1.0f - z * z);
  float phi = 2.0f * kPi * u2;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline float uniform_sphere_pdf() { return kInv4Pi; }

// Uniform upper hemisphere: pdf = 1 / (2 pi).
inline Vec3 square_to_uniform_hemisphere(float u1, float u2) {
  float z = u1;
  float r = safe_sqrt(1.0f - z * z);
  float phi = 2.0f * kPi * u2;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline float uniform_hemisphere_pdf(float cos_t) { return cos_t >= 0.0f ? kInv2Pi : 0.0f; }

// ---------------------------------------------------------------------------
// GGX (Trowbridge-Reitz), isotropic, alpha = roughness^2 (the caller maps it).

// D(h) = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2) for a unit half vector h;
// zero below the surface. The bracket is evaluated as sin^2 + alpha^2 cos^2 with
// sin^2 = h.x^2 + h.y^2: 1 - (n.h)^2 (1 - alpha^2) cancels catastrophically in
// float near the peak of sharp lobes (alpha^2 = 6e-6 at the roughness clamp).
inline float ggx_D(Vec3 h, float alpha) {
  if (!(h.z > 0.0f)) return 0.0f;
  float a2 = alpha * alpha;
  float d = h.x * h.x + h.y * h.y + a2 * h.z * h.z;
  return a2 / (kPi * d * d);
}

// Plain NDF sampling: h with density D(h) (n.h) over the hemisphere of normals.
// Inverting the CDF of cos^2(theta_h) gives cos^2 = (1-u) / ((1-u) + alpha^2 u) and
// sin^2 = alpha^2 u / ((1-u) + alpha^2 u), both computed directly (no 1 - cos^2).
inline Vec3 sample_ggx_ndf(float alpha, float u1, float u2) {
  float a2 = alpha * alpha;
  float one_minus_u = 1.0f - u1;
  float denom = one_minus_u + a2 * u1;
  float cos2 = denom > 0.0f ? one_minus_u / denom : 1.0f;
  float sin2 = denom > 0.0f ? a2 * u1 / denom : 0.0f;
  return spherical_direction(std::sqrt(std::clamp(sin2, 0.0f, 1.0f)), std::sqrt(std::clamp(cos2, 0.0f, 1.0f)),
                             2.0f * kPi * u2);
}
inline float ggx_ndf_pdf(Vec3 h, float alpha) { return ggx_D(h, alpha) * std::max(h.z, 0.0f); }

// Exact Smith masking for GGX: G1 = 2 cos / (cos + sqrt(alpha^2 sin^2 + cos^2)).
// (The Disney BRDF uses the Schlick-GGX approximation instead; this one belongs
// to the visible-normal distribution below.)
inline float ggx_smith_G1(Vec3 w, float alpha) {
  float c = w.z;
  if (c <= 0.0f) return 0.0f;
  return 2.0f * c / (c + std::sqrt(alpha * alpha * sin2_theta(w) + c * c));
}

// Visible-normal sampling (Heitz 2018, "Sampling the GGX Distribution of Visible
// Normals"): h with density G1(wo) max(0, wo.h) D(h) / (n.wo). Requires wo.z > 0.
inline Vec3 sample_ggx_vndf(Vec3 wo, float alpha, float u1, float u2) {
  Vec3 vh = normalize(Vec3(alpha * wo.x, alpha * wo.y, wo.z));
  float lensq = vh.x * vh.x + vh.y * vh.y;
  Vec3 t1 = lensq > 0.0f ? Vec3(-vh.y, vh.x, 0.0f) / std::sqrt(lensq) : Vec3(1.0f, 0.0f, 0.0f);
  Vec3 t2 = cross(vh, t1);
  float r = std::sqrt(u1);
  float phi = 2.0f * kPi * u2;
  float p1 = r * std::cos(phi), p2 = r * std::sin(phi);
  float s = 0.5f * (1.0f + vh.z);
  p2 = (1.0f - s) * safe_sqrt(1.0f - p1 * p1) + s * p2;
  Vec3 nh = p1 * t1 + p2 * t2 + safe_sqrt(1.0f - p1 * p1 - p2 * p2) * vh;
  return normalize(Vec3(alpha * nh.x, alpha * nh.y, std::max(1e-7f, nh.z)));
}
inline float ggx_vndf_pdf(Vec3 wo, Vec3 h, float alpha) {
  if (wo.z <= 0.0f) return 0.0f;
  return ggx_smith_G1(wo, alpha) * std::max(0.0f, dot(wo, h)) * ggx_D(h, alpha) / wo.z;
}

// Jacobian of the reflection map h -> wi = reflect(wo, h): dh/dwi = 1 / (4 |wo.h|).
inline float reflect_jacobian(float wo_dot_h) { return wo_dot_h > 0.0f ? 0.25f / wo_dot_h : 0.0f; }

// ---------------------------------------------------------------------------
// Multiple importance sampling heuristics (Veach). nf / ng are sample counts.
// Robust at the extremes: 0 when f's density is 0, 1 when only f's (squared)
// density overflows, 1/2 when both do, so the two strategies' weights still sum to 1.

inline float balance_heuristic(int nf, float f_pdf, int ng, float g_pdf) {
  float f = nf * f_pdf, g = ng * g_pdf;
  if (!(f > 0.0f)) return 0.0f;
  if (std::isinf(f)) return std::isinf(g) ? 0.5f : 1.0f;
  return f / (f + g);
}

inline float power_heuristic(int nf, float f_pdf, int ng, float g_pdf) {
  float f = nf * f_pdf, g = ng * g_pdf;
  if (!(f > 0.0f)) return 0.0f;
  float f2 = f * f, g2 = g * g;
  if (std::isinf(f2)) return std::isinf(g2) ? 0.5f : 1.0f;
  if (std::isinf(g2)) return 0.0f;
  return f2 / (f2 + g2);
}

}  // namespace ptir
