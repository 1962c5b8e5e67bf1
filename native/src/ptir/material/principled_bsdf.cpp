// Evaluation, sampling and analytic material derivatives of Cycles' Principled
// BSDF v1 (formulas in principled_bsdf.h).
//
// Derivatives. Per channel c, with dw_c = (1 - m) b_c, K_d the diffuse shape
// (bracket n.wi / pi), S the specular value without Fresnel, M_c = 1 + cspec0_c k
// the energy compensation (k = (1 - E) / E, zero for plain GGX):
//   f~_c = dw_c K_d + F_c S M_c,    F_c = cspec0_c (1 - FH) + FH
// cspec0_c = saturate(q_c), q_c = 0.08 s ((1 - t) + t b_c / L) (1 - m) + b_c m, L = lum(b):
//   df~_c/dcspec0_c = S ((1 - FH) M_c + F_c k)                    (0 where q_c is clamped)
//   dq_c/db_k = 0.08 s t (1 - m) (delta_ck / L - b_c w_k / L^2) + m delta_ck   (tint couples channels)
//   dq_c/dm   = -0.08 s ((1 - t) + t b_c / L) + b_c
//   df~_c/db_k = delta_ck (1 - m) K_d + df~_c/dcspec0_c dq_c/db_k
//   df~_c/dm   = -b_c K_d + df~_c/dcspec0_c dq_c/dm
//   df~_c/dr   = dw_c dK_d/dr + F_c (dS/dr M_c + S cspec0_c dk/dr)
//   dK_d/dr    = (n.wi / pi) (F_L + F_V + F_L F_V (2 R_R - 1)) (1 + wo.wi)
//   dS/dr      = 2 r dS/dalpha,  dS/dalpha = (D' G1o G1i + D G1o' G1i + D G1o G1i') / (4 n.wo)
//   D' = 2 alpha (s2 - alpha^2 t) / (pi d^3)  (d = s2 + alpha^2 t, t = (n.h)^2, s2 = 1 - t)
//   G1' = -2 c alpha sin^2 / ((c + q)^2 q),  q = sqrt(alpha^2 sin^2 + c^2)
//   dk/dr = -E_r / E^2 (slope of the table's interpolant)
// Below the roughness clamps (specular: kPrincipledMinRoughness; diffuse: [0, 1])
// the corresponding slope is zero.
#include "ptir/material/principled_bsdf.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "ptir/material/ggx_energy.h"
#include "ptir/math/sampling.h"

namespace ptir {

namespace {

// Cycles' luminance weights for the specular tint (closure.h, "m_cdlum").
constexpr float kTintLumR = 0.3f, kTintLumG = 0.6f, kTintLumB = 0.1f;

float schlick5(float cos_t) {
  float x = 1.0f - std::clamp(cos_t, 0.0f, 1.0f);
  float x2 = x * x;
  return x2 * x2 * x;
}

Vec3 half_vector_of(Vec3 wo, Vec3 wi) {
  Vec3 s = wo + wi;
  if (dot(s, s) > 1e-30f) return normalize(s);
  float m = max_component(vabs(s));
  if (!(m > 0.0f)) return Vec3(0.0f);
  return normalize(Vec3(s.x / m, s.y / m, s.z / m));
}

// dG1/dalpha of the exact Smith G1 = 2c / (c + sqrt(alpha^2 sin^2 + c^2)).
float smith_G1_dalpha(Vec3 w, float alpha) {
  const float c = w.z;
  if (!(c > 0.0f)) return 0.0f;
  const float s2 = sin2_theta(w);
  const float q = std::sqrt(alpha * alpha * s2 + c * c);
  const float cq = c + q;
  return -2.0f * c * alpha * s2 / (cq * cq * q);
}

}  // namespace

float smith_lambda(Vec3 w, float alpha) {
  const float c2 = w.z * w.z;
  if (!(c2 > 0.0f)) return 0.0f;
  const float t2 = sin2_theta(w) / c2;  // tan^2
  return 0.5f * (std::sqrt(1.0f + alpha * alpha * t2) - 1.0f);
}

float smith_lambda_dalpha(Vec3 w, float alpha) {
  const float c2 = w.z * w.z;
  if (!(c2 > 0.0f)) return 0.0f;
  const float t2 = sin2_theta(w) / c2;
  return 0.5f * alpha * t2 / std::sqrt(1.0f + alpha * alpha * t2);
}

float fresnel_dielectric(float cosi, float eta) {
  const float c = std::fabs(cosi);
  float g = eta * eta - 1.0f + c * c;
  if (!(g > 0.0f)) return 1.0f;  // total internal reflection
  g = std::sqrt(g);
  const float A = (g - c) / (g + c);
  const float B = (c * (g + c) - 1.0f) / (c * (g - c) + 1.0f);
  return 0.5f * A * A * (1.0f + B * B);
}

float specular_to_eta(float specular) {
  // s = 12.5 would make 0.08 s = 1 (eta = inf): Blender's soft range is [0, 1].
  const float s = std::clamp(specular, 0.0f, 12.0f);
  return 2.0f / (1.0f - std::sqrt(0.08f * s)) - 1.0f;
}

PrincipledBsdf::PrincipledBsdf(const MaterialParams& p, Vec3 wo, bool multiscatter, float min_specular_prob)
    : p_(p), wo_(wo) {
  above_ = wo.z > 0.0f;
  const float m = std::clamp(p.metallic, 0.0f, 1.0f);
  p_.metallic = m;
  r_ = std::clamp(p.roughness, kPrincipledMinRoughness, 1.0f);
  r_diffuse_ = std::clamp(p.roughness, 0.0f, 1.0f);
  alpha_ = r_ * r_;
  diffuse_weight_ = (1.0f - m) * p.albedo;

  // Fresnel: eta from Specular, F0 = Fd(1, eta), and the F0 colour cspec0.
  eta_ = specular_to_eta(p.specular);
  F0_ = fresnel_dielectric(1.0f, eta_);
  inv_1m_F0_ = 1.0f / (1.0f - F0_);
  const Vec3 b = p.albedo;
  const float L = kTintLumR * b.x + kTintLumG * b.y + kTintLumB * b.z;
  const Vec3 tint = L > 0.0f ? b / L : Vec3(1.0f);
  const Vec3 tmp = Vec3(1.0f - p.specular_tint) + tint * p.specular_tint;
  const Vec3 q = (0.08f * p.specular) * tmp * (1.0f - m) + b * m;
  cspec0_ = Vec3(std::clamp(q.x, 0.0f, 1.0f), std::clamp(q.y, 0.0f, 1.0f), std::clamp(q.z, 0.0f, 1.0f));
  if (!above_) return;

  G1o_ = ggx_smith_G1(wo, alpha_);
  multiscatter_ = multiscatter && p.roughness > kMultiscatterMinRoughness;
  if (multiscatter_) lambda_o_ = smith_lambda(wo, alpha_);
  F_V_ = schlick5(wo.z);
  if (multiscatter_) {
    GgxEnergy e = ggx_energy(wo.z, r_);
    ms_k_ = 1.0f / e.E - 1.0f;
    ms_dk_dr_ = -e.dE_dr / (e.E * e.E);
  }

  // Lobe selection weights, as Cycles' (the Fresnel colour at n.wo, and the diffuse
  // weight) but with the base colour replaced by a nominal 1/2 (F0 colour 0.08 s (1 - m) + m):
  // the albedo then changes no sampling decision, so its gradient (PRB holds
  // sampling fixed) equals the difference quotient of the estimator exactly.
  const float FH_n = (fresnel_dielectric(wo.z, eta_) - F0_) * inv_1m_F0_;
  const float c0 = std::clamp(0.08f * p.specular * (1.0f - m) + m, 0.0f, 1.0f);
  const float w_s = (c0 * (1.0f - FH_n) + FH_n) * (1.0f + c0 * ms_k_);
  const float w_d = 0.5f * (1.0f - m);
  p_spec_ = (w_s + w_d) > 0.0f ? std::clamp(w_s / (w_s + w_d), std::min(min_specular_prob, 1.0f - kMinDiffuseProb), 1.0f - kMinDiffuseProb) : 0.5f;
}

float PrincipledBsdf::diffuse_shape(Vec3 wi) const {
  const float FL = schlick5(wi.z), FV = F_V_;
  const float RR = r_diffuse_ * (1.0f + dot(wo_, wi));
  const float bracket = (1.0f - 0.5f * FV) * (1.0f - 0.5f * FL) + RR * (FL + FV + FL * FV * (RR - 1.0f));
  return bracket * wi.z * kInvPi;
}

PrincipledBsdf::SpecularTerms PrincipledBsdf::specular_terms(Vec3 wi) const {
  SpecularTerms t;
  t.h = half_vector_of(wo_, wi);
  if (!(t.h.z > 0.0f)) return t;
  const float D = ggx_D(t.h, alpha_);
  t.D = D;
  // Plain GGX: separable G1(wo) G1(wi); Multiscatter GGX's single-scattering part:
  // height-correlated G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (Cycles' multi-GGX).
  float G;
  if (multiscatter_) {
    G = 1.0f / (1.0f + lambda_o_ + smith_lambda(wi, alpha_));
  } else {
    t.G1i = ggx_smith_G1(wi, alpha_);
    G = G1o_ * t.G1i;
  }
  t.G = G;
  t.S = D * G * 0.25f / wo_.z;
  t.FH = (fresnel_dielectric(dot(wi, t.h), eta_) - F0_) * inv_1m_F0_;
  return t;
}

const PrincipledBsdf::Terms& PrincipledBsdf::terms(Vec3 wi) const {
  if (memo_set_ && std::memcmp(&memo_wi_, &wi, sizeof wi) == 0) return memo_;
  memo_.st = specular_terms(wi);
  memo_.Kd = diffuse_shape(wi);
  memo_wi_ = wi;
  memo_set_ = true;
  return memo_;
}

float PrincipledBsdf::specular_pdf(float D) const {
  // Visible normals reflected about h: G1(wo) max(0, wo.h) D / (n.wo) * 1 / (4 wo.h).
  return G1o_ * D * 0.25f / wo_.z;
}

Vec3 PrincipledBsdf::eval(Vec3 wi) const {
  if (!above_ || !(wi.z > 0.0f)) return Vec3(0.0f);
  const Terms& tm = terms(wi);
  const SpecularTerms& st = tm.st;
  const Vec3 F = cspec0_ * (1.0f - st.FH) + Vec3(st.FH);
  const Vec3 M = Vec3(1.0f) + cspec0_ * ms_k_;
  return diffuse_weight_ * tm.Kd + F * M * st.S;
}

Vec3 PrincipledBsdf::eval_diffuse(Vec3 wi) const {
  if (!above_ || !(wi.z > 0.0f)) return Vec3(0.0f);
  return diffuse_weight_ * terms(wi).Kd;
}

float PrincipledBsdf::pdf(Vec3 wi) const {
  if (!above_ || !(wi.z > 0.0f)) return 0.0f;
  const Vec3 h = half_vector_of(wo_, wi);
  const float ps = h.z > 0.0f ? specular_pdf(ggx_D(h, alpha_)) : 0.0f;
  return p_spec_ * ps + (1.0f - p_spec_) * wi.z * kInvPi;
}

BsdfEvalPdf PrincipledBsdf::eval_pdf(Vec3 wi) const {
  BsdfEvalPdf r;
  if (!above_ || !(wi.z > 0.0f)) return r;
  const Terms& tm = terms(wi);
  const SpecularTerms& st = tm.st;
  const Vec3 F = cspec0_ * (1.0f - st.FH) + Vec3(st.FH);
  const Vec3 M = Vec3(1.0f) + cspec0_ * ms_k_;
  r.f = diffuse_weight_ * tm.Kd + F * M * st.S;
  const float ps = st.h.z > 0.0f ? specular_pdf(st.D) : 0.0f;
  r.pdf = p_spec_ * ps + (1.0f - p_spec_) * wi.z * kInvPi;
  return r;
}

BsdfSample PrincipledBsdf::sample(float u1, float u2, float u3) const {
  BsdfSample s;
  if (!above_) return s;
  Vec3 wi;
  if (u1 < p_spec_) {
    const Vec3 h = sample_ggx_vndf(wo_, alpha_, u2, u3);
    wi = normalize(reflect(wo_, h));
  } else {
    wi = square_to_cosine_hemisphere(u2, u3);
  }
  if (!(wi.z > 0.0f)) return s;  // reflected below the surface: Cycles rejects it too
  BsdfEvalPdf ep = eval_pdf(wi);
  if (!(ep.pdf > 0.0f) || !std::isfinite(ep.pdf)) return s;
  s.wi = wi;
  s.pdf = ep.pdf;
  s.weight = Vec3(ep.f.x / ep.pdf, ep.f.y / ep.pdf, ep.f.z / ep.pdf);
  s.valid = true;
  return s;
}

const PrincipledBsdf::GradConstants& PrincipledBsdf::grad_constants() const {
  if (grad_set_) return grad_;
  const float m = p_.metallic, s = p_.specular, t = p_.specular_tint;
  const Vec3 b = p_.albedo;
  const float L = kTintLumR * b.x + kTintLumG * b.y + kTintLumB * b.z;
  const Vec3 tint = L > 0.0f ? b / L : Vec3(1.0f);
  const Vec3 q = (0.08f * s) * (Vec3(1.0f - t) + tint * t) * (1.0f - m) + b * m;
  const float lum_w[3] = {kTintLumR, kTintLumG, kTintLumB};
  for (int c = 0; c < 3; ++c) {
    grad_.free[c] = q[c] > 0.0f && q[c] < 1.0f;  // d cspec0 / d q is 0 where clamped
    // dq_c / db_k: the metallic mix (diagonal) and the tint (couples the channels).
    for (int k = 0; k < 3; ++k) {
      float dq = (c == k ? m : 0.0f);
      if (L > 0.0f) dq += 0.08f * s * t * (1.0f - m) * ((c == k ? 1.0f / L : 0.0f) - b[c] * lum_w[k] / (L * L));
      grad_.dq[c][k] = dq;
    }
    grad_.dq_dm[c] = -0.08f * s * ((1.0f - t) + t * tint[c]) + b[c];
  }
  grad_.wo_dalpha = multiscatter_ ? smith_lambda_dalpha(wo_, alpha_) : smith_G1_dalpha(wo_, alpha_);
  grad_set_ = true;
  return grad_;
}

Vec3 PrincipledBsdf::eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const {
  if (!above_ || !(wi.z > 0.0f)) return Vec3(0.0f);
  const float m = p_.metallic;
  const Vec3 b = p_.albedo;
  const GradConstants& gc = grad_constants();

  // Values.
  const Terms& tm = terms(wi);
  const float Kd = tm.Kd;
  const SpecularTerms& st = tm.st;
  const float S = st.S, FH = st.FH;
  const Vec3 F = cspec0_ * (1.0f - FH) + Vec3(FH);
  const Vec3 M = Vec3(1.0f) + cspec0_ * ms_k_;
  const Vec3 f = diffuse_weight_ * Kd + F * M * S;

  // d f~_c / d cspec0_c, zero where cspec0 is clamped.
  Vec3 P;
  for (int c = 0; c < 3; ++c) P[c] = gc.free[c] ? S * ((1.0f - FH) * M[c] + F[c] * ms_k_) : 0.0f;

  // Albedo: diffuse (diagonal) + specular through cspec0 (the tint couples channels).
  for (int k = 0; k < 3; ++k) {
    float acc = d_f[k] * (1.0f - m) * Kd;
    for (int c = 0; c < 3; ++c) acc += d_f[c] * P[c] * gc.dq[c][k];
    g.d_albedo[k] += acc;
  }

  // Metallic.
  float dm = 0.0f;
  for (int c = 0; c < 3; ++c) dm += d_f[c] * (-b[c] * Kd + P[c] * gc.dq_dm[c]);
  g.d_metallic += dm;

  // Roughness: the diffuse retro-reflection term and the specular lobe.
  float dKd_dr = 0.0f;
  if (p_.roughness >= 0.0f && p_.roughness <= 1.0f) {
    const float FL = schlick5(wi.z), FV = F_V_;
    const float lv1 = 1.0f + dot(wo_, wi);
    const float RR = r_diffuse_ * lv1;
    dKd_dr = (FL + FV + FL * FV * (2.0f * RR - 1.0f)) * lv1 * wi.z * kInvPi;
  }
  float dS_dr = 0.0f;
  if (p_.roughness >= kPrincipledMinRoughness && p_.roughness <= 1.0f && st.h.z > 0.0f) {
    const Vec3 h = st.h;
    const float a = alpha_, a2 = a * a;
    const float tt = h.z * h.z, s2 = h.x * h.x + h.y * h.y;
    const float d = s2 + a2 * tt;
    const float D = a2 / (kPi * d * d);
    const float dD = 2.0f * a * (s2 - a2 * tt) / (kPi * d * d * d);
    // G and G1(wi) as S took them (terms); their alpha slopes.
    const float G = st.G;
    const float dG = multiscatter_ ? -G * G * (gc.wo_dalpha + smith_lambda_dalpha(wi, a))
                                   : gc.wo_dalpha * st.G1i + G1o_ * smith_G1_dalpha(wi, a);
    const float dS_da = (dD * G + D * dG) * 0.25f / wo_.z;
    dS_dr = dS_da * 2.0f * r_;
  }
  const float dk_dr = (multiscatter_ && p_.roughness <= 1.0f) ? ms_dk_dr_ : 0.0f;
  float dr = 0.0f;
  for (int c = 0; c < 3; ++c) dr += d_f[c] * (diffuse_weight_[c] * dKd_dr + F[c] * (dS_dr * M[c] + S * cspec0_[c] * dk_dr));
  g.d_roughness += dr;
  return f;
}

}  // namespace ptir
