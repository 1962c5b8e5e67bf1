// The simplified Disney BRDF of PTIR (docs/method.md §4, paper appendix A):
//
//   f  = (1 - m) (a / pi) (1 - F)  +  D F G / (4 (n.wi) (n.wo))
//   h  = normalize(wo + wi)
//   F0 = (1 - m) 0.04 + m a,   F = F0 + (1 - F0) (1 - max(wo.h, 0))^5   (per channel)
//   D  = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2),   alpha = r^2,  r >= kMinRoughness
//   G  = G1(wi) G1(wo),   G1(w) = (n.w) / ((n.w)(1 - k) + k),   k = alpha / 2
//
// Everything works in the local shading frame (z = n; build it with Frame from
// vec.h). wo and wi are unit vectors pointing away from the surface.
//
// Conventions (Mitsuba 3 style): disney_eval returns the cosine-weighted value
// f~ = f max(n.wi, 0); disney_sample returns weight = f~ / pdf. Sampling is a
// fixed 50/50 mixture of a cosine-weighted hemisphere (diffuse) and GGX NDF
// half-vector sampling reflected about h (specular); disney_pdf is the mixture
// density, whichever lobe produced the direction.
//
// Analytic derivatives of f~ with respect to albedo, roughness and metallic
// (paper appendix B) are in disney_eval_grad (disney_brdf.cpp).
//
// Note: f is reciprocal, but the dielectric part is not energy conserving at
// grazing wo (the diffuse lobe is weighted by 1 - F(wo.h), not by what the
// specular lobe actually takes): with albedo 1 the directional albedo reaches
// 1.35 at 80 deg and 1.73 at 89 deg for roughness 0.05 (<= 1 up to ~45 deg).
// Metals (F = 1) stay <= 1. This is the published model, kept as is; see the
// white-furnace table printed by tests/native/test_brdf.cpp.
#pragma once

#include <algorithm>
#include <cmath>

#include "ptir/material/material_params.h"
#include "ptir/math/sampling.h"
#include "ptir/math/vec.h"

namespace ptir {

// Roughness is clamped to at least this before alpha = r^2 (keeps GGX finite).
// Below the clamp the roughness derivative is zero.
constexpr float kMinRoughness = 0.05f;
// Fresnel reflectance at normal incidence of the dielectric (non-metal) part.
constexpr float kDielectricF0 = 0.04f;
// Probability that disney_sample draws from the GGX specular lobe; the diffuse
// (cosine hemisphere) lobe gets 1 - kSpecularLobeProb. docs/method.md §4 (and PTIR) fix
// it to 1/2. A roughness/metallic-aware choice (e.g. in proportion to each
// lobe's estimated albedo, with metals always picking specular) would reduce
// variance for glossy dielectrics and metals; disney_pdf and every MIS weight
// would then have to use the same probability.
constexpr float kSpecularLobeProb = 0.5f;
// Smallest wo.h used in the reflection Jacobian 1 / (4 wo.h). Only reached when
// wo and wi are both within ~1e-12 of the horizon and nearly opposite; keeps
// the density (and its square in the power heuristic) finite.
constexpr float kMinWoDotH = 1e-12f;

// The simplified model reads albedo, roughness and metallic (specular inputs are ignored).
using DisneyParams = MaterialParams;
using DisneySample = BsdfSample;
using DisneyEvalPdf = BsdfEvalPdf;
using DisneyGrad = MaterialGrad;

inline float disney_alpha(float roughness) {
  float r = std::max(roughness, kMinRoughness);
  return r * r;
}

inline Vec3 disney_F0(const DisneyParams& p) {
  return Vec3(kDielectricF0 * (1.0f - p.metallic)) + p.metallic * p.albedo;
}

// Schlick weight (1 - max(cos, 0))^5.
inline float schlick_weight(float cos_t) {
  float x = 1.0f - std::clamp(cos_t, 0.0f, 1.0f);
  float x2 = x * x;
  return x2 * x2 * x;
}

// Schlick-GGX masking term G1(w) = (n.w) / ((n.w)(1 - k) + k).
inline float schlick_ggx_G1(float cos_t, float k) { return cos_t / (cos_t * (1.0f - k) + k); }

namespace disney_detail {

// Density of the specular strategy over wi: D(h) (n.h) / (4 (wo.h)).
inline float specular_pdf(float alpha, Vec3 h, float wo_dot_h) {
  return ggx_D(h, alpha) * h.z * 0.25f / std::max(wo_dot_h, kMinWoDotH);
}

inline float mixture_pdf(float alpha, Vec3 wo, Vec3 wi, Vec3 h) {
  float pdf_diffuse = wi.z * kInvPi;
  float pdf_specular = specular_pdf(alpha, h, dot(wo, h));
  return (1.0f - kSpecularLobeProb) * pdf_diffuse + kSpecularLobeProb * pdf_specular;
}

// Half vector of two upper-hemisphere directions (their sum has z > 0). When the
// sum is tiny (both within ~1e-15 of the horizon and nearly opposite) it is
// rescaled before normalising so that its squared length does not underflow.
inline Vec3 half_vector(Vec3 wo, Vec3 wi) {
  Vec3 s = wo + wi;
  if (dot(s, s) > 1e-30f) return normalize(s);
  float m = max_component(vabs(s));
  if (!(m > 0.0f)) return Vec3(0.0f);
  return normalize(Vec3(s.x / m, s.y / m, s.z / m));
}

// f~ for upper-hemisphere wo, wi with half vector h (see disney_eval).
inline Vec3 eval_with_half_vector(const DisneyParams& p, float alpha, Vec3 wo, Vec3 wi, Vec3 h) {
  if (!(h.z > 0.0f)) return Vec3(0.0f);  // degenerate sum (underflow): nothing to reflect
  float cos_o = wo.z, cos_i = wi.z;
  float k = 0.5f * alpha;
  Vec3 F0 = disney_F0(p);
  float c = schlick_weight(dot(wo, h));
  Vec3 F = F0 + (Vec3(1.0f) - F0) * c;
  float D = ggx_D(h, alpha);
  // D G / (4 cos_i cos_o) * cos_i with G1(wo) / cos_o = 1 / (cos_o (1 - k) + k):
  // no division by a small cosine, so no epsilon is needed.
  float spec = D * schlick_ggx_G1(cos_i, k) * 0.25f / (cos_o * (1.0f - k) + k);
  Vec3 diffuse = ((1.0f - p.metallic) * kInvPi * cos_i) * p.albedo * (Vec3(1.0f) - F);
  return diffuse + spec * F;
}

}  // namespace disney_detail

// Cosine-weighted BRDF f~ = f(wo, wi) max(n.wi, 0); zero unless n.wo > 0 and n.wi > 0.
inline Vec3 disney_eval(const DisneyParams& p, Vec3 wo, Vec3 wi) {
  if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return Vec3(0.0f);
  Vec3 h = disney_detail::half_vector(wo, wi);
  return disney_detail::eval_with_half_vector(p, disney_alpha(p.roughness), wo, wi, h);
}

// Mixture density of disney_sample over wi (solid angle); zero unless both are above.
inline float disney_pdf(const DisneyParams& p, Vec3 wo, Vec3 wi) {
  if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return 0.0f;
  Vec3 h = disney_detail::half_vector(wo, wi);
  return disney_detail::mixture_pdf(disney_alpha(p.roughness), wo, wi, h);
}

// Both at once (one half vector): what next-event estimation needs for MIS.
inline DisneyEvalPdf disney_eval_pdf(const DisneyParams& p, Vec3 wo, Vec3 wi) {
  DisneyEvalPdf r;
  if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return r;
  Vec3 h = disney_detail::half_vector(wo, wi);
  float alpha = disney_alpha(p.roughness);
  r.f = disney_detail::eval_with_half_vector(p, alpha, wo, wi, h);
  r.pdf = disney_detail::mixture_pdf(alpha, wo, wi, h);
  return r;
}

// Draws wi: u1 picks the lobe (u1 < kSpecularLobeProb: GGX specular, else diffuse),
// (u2, u3) sample the lobe. Invalid when wo or the drawn wi is not above the surface.
inline DisneySample disney_sample(const DisneyParams& p, Vec3 wo, float u1, float u2, float u3) {
  DisneySample s;
  if (!(wo.z > 0.0f)) return s;
  float alpha = disney_alpha(p.roughness);
  Vec3 wi;
  if (u1 < kSpecularLobeProb) {
    Vec3 h = sample_ggx_ndf(alpha, u2, u3);
    float wo_dot_h = dot(wo, h);
    if (!(wo_dot_h > 0.0f)) return s;
    wi = normalize(reflect(wo, h));
  } else {
    wi = square_to_cosine_hemisphere(u2, u3);
  }
  if (!(wi.z > 0.0f)) return s;
  DisneyEvalPdf ep = disney_eval_pdf(p, wo, wi);
  const float pdf = ep.pdf;
  if (!(pdf > 0.0f) || !std::isfinite(pdf)) return s;
  s.wi = wi;
  s.pdf = pdf;
  s.weight = Vec3(ep.f.x / pdf, ep.f.y / pdf, ep.f.z / pdf);  // true divisions: 1/pdf may overflow
  s.valid = true;
  return s;
}

// Accumulates into `grad` the adjoints of albedo, roughness and metallic given the
// adjoint d_f of the cosine-weighted value f~ = disney_eval(p, wo, wi):
//   grad.d_albedo[k] += sum_c d_f[c] df~_c/da_k  (= d_f[k] df~_k/da_k, channels decouple)
//   grad.d_roughness += d_f . df~/dr   (zero when r < kMinRoughness)
//   grad.d_metallic  += d_f . df~/dm
// Closed form (no autodiff). Returns f~ (the value it had to compute anyway).
Vec3 disney_eval_grad(const DisneyParams& p, Vec3 wo, Vec3 wi, Vec3 d_f, DisneyGrad& grad);

}  // namespace ptir
