// Analytic material derivatives of the cosine-weighted simplified Disney BRDF.
//
// Write cos_i = n.wi, cos_o = n.wo, t = (n.h)^2, c = (1 - max(wo.h, 0))^5 and
//   B_i = cos_i (1 - k) + k,  B_o = cos_o (1 - k) + k,   k = alpha / 2,
//   Q   = G1(wi) / B_o = cos_i / (B_i B_o)     (so G / (4 cos_i cos_o) * cos_i = Q / 4),
//   K   = D Q / 4                               (the paper's kappa * cos_i).
// Then, per channel j,
//   f~_j = (1 - m) (a_j / pi) (1 - F_j) cos_i  +  K F_j,
//   F_j  = F0_j (1 - c) + c,   F0_j = (1 - m) 0.04 + m a_j.
//
// Albedo (channels decouple: dF_j/da_l = 0 for j != l):
//   dF_j/da_j    = m (1 - c)
//   df~_j/da_j   = cos_i (1 - m)/pi [(1 - F_j) - a_j m (1 - c)]  +  K m (1 - c)
// Metallic:
//   dF_j/dm      = (a_j - 0.04)(1 - c)
//   df~_j/dm     = -cos_i (a_j/pi) [(1 - F_j) + (1 - m)(a_j - 0.04)(1 - c)]  +  K (a_j - 0.04)(1 - c)
// Roughness (only K depends on alpha; alpha = r^2, dalpha/dr = 2r above the clamp):
//   d = t (alpha^2 - 1) + 1 = s2 + alpha^2 t  (s2 = 1 - t = sin^2 theta_h),  D = alpha^2 / (pi d^2)
//   dD/dalpha = 2 alpha (1 - t - alpha^2 t) / (pi d^3) = 2 alpha (s2 - alpha^2 t) / (pi d^3)
//   dQ/dk     = -Q [(1 - cos_i)/B_i + (1 - cos_o)/B_o],   dk/dalpha = 1/2
//   dK/dalpha = (dD/dalpha Q + D dQ/dk / 2) / 4
//   df~_j/dr  = F_j dK/dalpha 2r
// These agree with the paper's appendix B (its eq. for df/da_k, df/dr, df/dm)
// with denom = 4 cos_o cos_i and no epsilon: the cos_o of G1(wo) is cancelled
// analytically, so nothing divides by a small cosine.
#include "ptir/material/disney_brdf.h"

namespace ptir {

Vec3 disney_eval_grad(const DisneyParams& p, Vec3 wo, Vec3 wi, Vec3 d_f, DisneyGrad& grad) {
  float cos_o = wo.z, cos_i = wi.z;
  if (!(cos_o > 0.0f) || !(cos_i > 0.0f)) return Vec3(0.0f);
  Vec3 h = disney_detail::half_vector(wo, wi);
  if (!(h.z > 0.0f)) return Vec3(0.0f);
  const float m = p.metallic;
  const Vec3 a = p.albedo;
  const bool above_clamp = p.roughness >= kMinRoughness;
  const float r = std::max(p.roughness, kMinRoughness);
  const float alpha = r * r;
  const float a2 = alpha * alpha;
  const float k = 0.5f * alpha;

  const float c = schlick_weight(dot(wo, h));
  const float one_minus_c = 1.0f - c;
  const Vec3 F0 = disney_F0(p);
  const Vec3 F = F0 + (Vec3(1.0f) - F0) * c;
  const Vec3 one_minus_F = Vec3(1.0f) - F;

  // t = cos^2 theta_h, s2 = sin^2 theta_h from h.x, h.y (no cancellation; see ggx_D).
  const float t = h.z * h.z;
  const float s2 = h.x * h.x + h.y * h.y;
  const float d = s2 + a2 * t;
  const float D = a2 / (kPi * d * d);
  const float B_i = cos_i * (1.0f - k) + k;
  const float B_o = cos_o * (1.0f - k) + k;
  const float Q = cos_i / (B_i * B_o);
  const float K = 0.25f * D * Q;

  const float diffuse_scale = (1.0f - m) * kInvPi * cos_i;
  const Vec3 f = diffuse_scale * a * one_minus_F + K * F;

  // Albedo.
  const float dF_da = m * one_minus_c;
  Vec3 df_da = diffuse_scale * (one_minus_F - a * dF_da) + Vec3(K * dF_da);
  grad.d_albedo += d_f * df_da;

  // Metallic.
  const Vec3 dF_dm = (a - Vec3(kDielectricF0)) * one_minus_c;
  Vec3 df_dm = -(kInvPi * cos_i) * a * (one_minus_F + (1.0f - m) * dF_dm) + K * dF_dm;
  grad.d_metallic += dot(d_f, df_dm);

  // Roughness, through alpha = r^2; the clamp max(r, kMinRoughness) has zero slope below.
  if (above_clamp) {
    const float dD_dalpha = 2.0f * alpha * (s2 - a2 * t) / (kPi * d * d * d);
    const float dQ_dk = -Q * ((1.0f - cos_i) / B_i + (1.0f - cos_o) / B_o);
    const float dK_dalpha = 0.25f * (dD_dalpha * Q + 0.5f * D * dQ_dk);
    grad.d_roughness += dot(d_f, F) * dK_dalpha * 2.0f * r;
  }
  return f;
}

}  // namespace ptir
