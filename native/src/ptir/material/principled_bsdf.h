// Cycles' Principled BSDF, v1 (Blender 3.x; read from Cycles at tag v3.4:
// kernel/svm/closure.h case CLOSURE_BSDF_PRINCIPLED_ID, bsdf_principled_diffuse.h,
// bsdf_microfacet.h, bsdf_util.h; ../shared/docs/PRINCIPLED.md). With base colour
// b, metallic m, specular s, specular tint t, roughness r, the node emits the SUM
// of two closures (nothing couples them):
//
//   diffuse  (1 - m) b / pi [ (1 - F_V/2)(1 - F_L/2) + R_R (F_L + F_V + F_L F_V (R_R - 1)) ]
//            F_x = (1 - n.x)^5,  R_R = r (1 + wo.wi)   (raw roughness)
//   specular F D G / (4 (n.wo)(n.wi))                   (GGX, alpha = r^2)
//            D  = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)
//            G  = G1(wo) G1(wi), G1 = 2 / (1 + sqrt(1 + alpha^2 tan^2))   (separable exact Smith)
//            F  = cspec0 (1 - FH) + FH,  FH = (Fd(wi.h, eta) - F0) / (1 - F0),  F0 = Fd(1, eta)
//            eta    = 2 / (1 - sqrt(0.08 s)) - 1
//            cspec0 = saturate(0.08 s ((1 - t) + t b / lum(b)) (1 - m) + b m),  lum = 0.3 R + 0.6 G + 0.1 B
//
// "Multiscatter GGX" (a random walk in Cycles, no closed form) is matched in
// expectation by its single-scattering lobe -- which Cycles evaluates with the
// height-correlated G2 = 1 / (1 + Lambda(wo) + Lambda(wi)), Lambda = (sqrt(1 +
// alpha^2 tan^2) - 1) / 2 -- with energy compensation:
//   f_spec *= 1 + cspec0 (1 - E(n.wo, r)) / E(n.wo, r)       (ggx_energy.h)
// and, as in Cycles, plain GGX is used whenever r <= 0.075.
//
// Sampling (Cycles picks a closure by its sample weight; we use alike weights as
// a one-sample mixture): the specular lobe by GGX visible normals (pdf
// G1(wo) D / (4 n.wo)) with probability P_spec = w_s / (w_s + w_d), w_s = the
// Fresnel value at n.wo (as Cycles' bsdf_microfacet_fresnel_color), w_d = the
// diffuse weight (1 - m) b — both with a nominal base colour b = 1/2, so that the
// albedo changes no sampling decision; P_spec is kept within [0.1, 0.9] so both
// lobes always have density (the derivative of either lobe is then estimated
// everywhere); the inversion raises the specular bound to 1/2 (optim/optimizer_setup),
// where specular samples carry the roughness and highlight gradients. The diffuse
// lobe is cosine-weighted.
//
// Roughness below kPrincipledMinRoughness is clamped for the specular lobe (Cycles
// switches to a delta mirror when alpha^2 <= 1e-7, i.e. r < 0.018; our transport
// has no delta BSDFs, so the mirror is a GGX lobe of r = 0.02).
//
// The object is bound to one vertex's wo: per-vertex constants (Fresnel colour,
// G1(wo), lobe probability, energy compensation) are computed once.
#pragma once

#include "ptir/material/material_params.h"
#include "ptir/math/vec.h"

namespace ptir {

constexpr float kPrincipledMinRoughness = 0.02f;
// Cycles uses single-scattering GGX for the "Multiscatter GGX" distribution at or below this roughness.
constexpr float kMultiscatterMinRoughness = 0.075f;
// Bounds of the specular lobe's selection probability.
// (the specular bound is the default of IntegratorSettings::min_specular_probability).
constexpr float kMinSpecularProb = 0.1f;
constexpr float kMinDiffuseProb = 0.1f;

// Exact unpolarised Fresnel reflectance of a dielectric interface (cosi = cos of
// the incident angle, eta = relative IOR); 1 under total internal reflection.
float fresnel_dielectric(float cosi, float eta);

// Blender's Specular input to the IOR Cycles uses: eta = 2 / (1 - sqrt(0.08 s)) - 1.
float specular_to_eta(float specular);

// Smith's Lambda of GGX for direction w (local frame) and its alpha derivative.
float smith_lambda(Vec3 w, float alpha);
float smith_lambda_dalpha(Vec3 w, float alpha);

class PrincipledBsdf {
 public:
  // min_specular_prob: lower bound of the specular lobe's selection probability
  // (sampling only: any bound gives the same expectation).
  PrincipledBsdf(const MaterialParams& p, Vec3 wo, bool multiscatter, float min_specular_prob = kMinSpecularProb);

  Vec3 eval(Vec3 wi) const;   // f~ = f max(n.wi, 0); zero unless n.wo > 0 and n.wi > 0
  Vec3 eval_diffuse(Vec3 wi) const;  // the diffuse lobe's part of eval
  float pdf(Vec3 wi) const;   // density of sample()
  BsdfEvalPdf eval_pdf(Vec3 wi) const;
  // u1 picks the lobe, (u2, u3) sample it.
  BsdfSample sample(float u1, float u2, float u3) const;
  // Adds to g the adjoints of albedo, roughness and metallic for the adjoint d_f
  // of f~(wo, wi); returns f~. Closed form (principled_bsdf.cpp).
  Vec3 eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const;

  float specular_probability() const { return p_spec_; }
  const Vec3& cspec0() const { return cspec0_; }

 private:
  // Per-channel specular value S (no Fresnel, no compensation) and Fresnel blend FH at wi.
  struct SpecularTerms {
    float S = 0.0f;   // D G1(wo) G1(wi) / (4 n.wo)   (cosine-weighted, F = 1)
    float D = 0.0f;   // GGX D(h)
    float FH = 0.0f;  // interpolation factor of the Fresnel colour
    float G = 0.0f;   // the shadowing-masking term in S
    float G1i = 0.0f; // plain GGX: G1(wi) (G = G1(wo) G1(wi))
    Vec3 h;
  };
  SpecularTerms specular_terms(Vec3 wi) const;
  float diffuse_shape(Vec3 wi) const;  // the bracket of the diffuse lobe times n.wi / pi
  // Both at wi, remembered for the last wi: the gradient replay evaluates eval_pdf
  // (or sample) and then eval_grad at the same direction (the same values either way).
  struct Terms {
    SpecularTerms st;
    float Kd = 0.0f;
  };
  const Terms& terms(Vec3 wi) const;
  float specular_pdf(float D) const;  // density of the specular strategy, given D(h)

  MaterialParams p_;
  Vec3 wo_;
  bool above_ = false;        // n.wo > 0
  float r_ = 0.5f;            // roughness, clamped for the specular lobe
  float r_diffuse_ = 0.5f;    // roughness in [0, 1] for the retro-reflection term
  float alpha_ = 0.25f;
  float eta_ = 1.5f, F0_ = 0.04f, inv_1m_F0_ = 1.0f;
  Vec3 cspec0_;
  Vec3 diffuse_weight_;       // (1 - m) b
  float G1o_ = 1.0f;
  float F_V_ = 0.0f;          // (1 - n.wo)^5 of the diffuse lobe
  bool multiscatter_ = false; // compensation active (multiscatter and r > 0.075)
  float lambda_o_ = 0.0f;     // Smith Lambda(wo) (height-correlated G of Multiscatter GGX)
  float ms_k_ = 0.0f;         // (1 - E) / E at n.wo
  float ms_dk_dr_ = 0.0f;
  float p_spec_ = 0.5f;
  // What eval_grad needs that depends on the vertex alone (its first call fills it):
  // d cspec0_c / d b_k (dq[c][k]), d cspec0_c / d m, where cspec0 is not clamped,
  // and the alpha slope of wo's shadowing (Lambda(wo) or G1(wo)).
  struct GradConstants {
    float dq[3][3];
    float dq_dm[3];
    bool free[3];
    float wo_dalpha;
  };
  const GradConstants& grad_constants() const;
  mutable bool grad_set_ = false;
  mutable GradConstants grad_;
  mutable bool memo_set_ = false;
  mutable Vec3 memo_wi_;
  mutable Terms memo_;
};

}  // namespace ptir
