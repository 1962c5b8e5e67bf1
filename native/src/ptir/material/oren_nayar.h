// Blender's Diffuse BSDF node as Cycles evaluates it (bsdf_oren_nayar.h,
// bsdf_diffuse.h at v3.4): roughness sigma = 0 is Lambert, sigma > 0 Oren-Nayar
//   f = b (A + B s / t'),  A = 1 / (pi + (3 pi - 4) sigma / 6),  B = sigma A,
//   s = wo.wi - (n.wo)(n.wi),  t' = max(n.wi, n.wo) if s > 0 else 1
// (sigma = 0 gives A = 1/pi, B = 0: the same formula). Sampled cosine-weighted.
// Derivatives: df~/db = n.wi (A + B s/t'), df~/dsigma = b n.wi (A' + B' s/t') with
// A' = -c A^2 (c = (3 pi - 4) / 6), B' = A + sigma A'. No metallic.
#pragma once

#include <algorithm>
#include <cmath>

#include "ptir/material/material_params.h"
#include "ptir/math/sampling.h"

namespace ptir {

// A diffuse lobe's sample: wi cosine-weighted (as Cycles samples its diffuse closures),
// weighted by the lobe's eval / pdf.
template <class Lobe>
BsdfSample sample_cosine(const Lobe& lobe, Vec3 wo, float u2, float u3) {
  BsdfSample s;
  if (!(wo.z > 0.0f)) return s;
  const Vec3 wi = square_to_cosine_hemisphere(u2, u3);
  const float pdf_wi = lobe.pdf(wi);
  if (!(pdf_wi > 0.0f)) return s;
  s.wi = wi;
  s.pdf = pdf_wi;
  s.weight = lobe.eval(wi) / pdf_wi;
  s.valid = true;
  return s;
}

class OrenNayarBsdf {
 public:
  OrenNayarBsdf(const MaterialParams& p, Vec3 wo) : b_(p.albedo), wo_(wo), raw_sigma_(p.roughness) {
    sigma_ = std::clamp(p.roughness, 0.0f, 1.0f);
    A_ = 1.0f / (kPi + kC * sigma_);
    B_ = sigma_ * A_;
  }

  Vec3 eval(Vec3 wi) const { return b_ * shape(wi); }
  float pdf(Vec3 wi) const { return wo_.z > 0.0f && wi.z > 0.0f ? wi.z * kInvPi : 0.0f; }
  BsdfEvalPdf eval_pdf(Vec3 wi) const { return {eval(wi), pdf(wi)}; }
  BsdfSample sample(float /*u1*/, float u2, float u3) const { return sample_cosine(*this, wo_, u2, u3); }
  Vec3 eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const {
    const float k = shape(wi);
    if (!(k > 0.0f)) return Vec3(0.0f);
    g.d_albedo += d_f * k;
    if (raw_sigma_ >= 0.0f && raw_sigma_ <= 1.0f) {
      const float dA = -kC * A_ * A_, dB = A_ + sigma_ * dA;
      g.d_roughness += dot(d_f, b_) * wi.z * (dA + dB * ratio(wi));
    }
    return b_ * k;
  }

 private:
  static constexpr float kC = (3.0f * kPi - 4.0f) / 6.0f;
  // s / t' of Cycles (t' = max(n.wi, n.wo) when s > 0).
  float ratio(Vec3 wi) const {
    const float s = dot(wo_, wi) - wo_.z * wi.z;
    return s > 0.0f ? s / (std::max(wi.z, wo_.z) + 1e-38f) : s;
  }
  float shape(Vec3 wi) const {
    if (!(wo_.z > 0.0f) || !(wi.z > 0.0f)) return 0.0f;
    return std::max(0.0f, wi.z * (A_ + B_ * ratio(wi)));
  }
  Vec3 b_, wo_;
  float raw_sigma_, sigma_, A_, B_;
};

}  // namespace ptir
