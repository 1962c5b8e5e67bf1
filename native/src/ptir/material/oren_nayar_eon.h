// Blender's Diffuse BSDF node as Cycles 4.3 and later evaluate it (svm/closure.h
// CLOSURE_BSDF_DIFFUSE_ID, closure/bsdf_oren_nayar.h): roughness sigma < 1e-5 is
// Lambert, otherwise the energy-preserving Oren-Nayar -- Fujii's improved model plus
// OpenPBR's multiple-scattering term, the closure Principled v2 uses for its
// Diffuse Roughness (principled_v2.cpp) --
//   f~ = b n.wi (a + b_on t + m(rho) (1 - E(n.wi))),  t = s / max(n.wi, n.wo) if s > 0 else s,
//   a = 1 / (pi + sigma (pi/2 - 2/3)),  b_on = sigma a,  E(mu) = a pi + b_on G(mu),
//   m(rho) = rho^2 E_avg / (1 - E_avg) / (pi (1 - rho (1 - E_avg))) (1 - E(n.wo)),
//   E_avg = a pi + (2 pi - 5.6) / 3 b_on,  rho = saturate(b)
// with s = wo.wi - (n.wo)(n.wi). Sampled cosine-weighted, as Cycles. Under v1
// (Blender 3.x) the node is oren_nayar.h; resolve_bsdf (bsdf.h) picks by the model.
// Gradients: the same formula with dual numbers (dual.h) in b (R, G, B) and sigma.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include "ptir/material/dual.h"
#include "ptir/material/material_params.h"
#include "ptir/material/oren_nayar.h"
#include "ptir/material/principled_v2_lobes.h"
#include "ptir/math/sampling.h"

namespace ptir {

class OrenNayarEonBsdf {
 public:
  OrenNayarEonBsdf(const MaterialParams& p, Vec3 wo) : b_(p.albedo), wo_(wo), raw_sigma_(p.roughness) {}

  Vec3 eval(Vec3 wi) const {
    const std::array<float, 3> f = value<float>({b_.x, b_.y, b_.z}, raw_sigma_, wi);
    return Vec3(f[0], f[1], f[2]);
  }
  float pdf(Vec3 wi) const { return wo_.z > 0.0f && wi.z > 0.0f ? wi.z * kInvPi : 0.0f; }
  BsdfEvalPdf eval_pdf(Vec3 wi) const { return {eval(wi), pdf(wi)}; }
  BsdfSample sample(float /*u1*/, float u2, float u3) const { return sample_cosine(*this, wo_, u2, u3); }
  Vec3 eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const {
    using D = Dual<4>;  // d/d(b R, G, B, sigma)
    const std::array<D, 3> f = value<D>({D::variable(b_.x, 0), D::variable(b_.y, 1), D::variable(b_.z, 2)},
                                        D::variable(raw_sigma_, 3), wi);
    const float d[3] = {d_f.x, d_f.y, d_f.z};
    for (int c = 0; c < 3; ++c) {
      g.d_albedo.x += d[c] * f[size_t(c)].d[0];
      g.d_albedo.y += d[c] * f[size_t(c)].d[1];
      g.d_albedo.z += d[c] * f[size_t(c)].d[2];
      g.d_roughness += d[c] * f[size_t(c)].d[3];
    }
    return Vec3(f[0].v, f[1].v, f[2].v);
  }

 private:
  // f~(wo, wi) per channel for base colour b and the node's raw roughness.
  template <class T>
  std::array<T, 3> value(const std::array<T, 3>& b, const T& raw_sigma, Vec3 wi) const {
    std::array<T, 3> f{T(0.0f), T(0.0f), T(0.0f)};
    if (!(wo_.z > 0.0f) || !(wi.z > 0.0f)) return f;
    if (value_of(raw_sigma) < kClosureWeightCutoff) {  // Lambert (Cycles: roughness < 1e-5)
      for (int c = 0; c < 3; ++c) f[size_t(c)] = max_by_value(b[size_t(c)], T(0.0f)) * (wi.z * kInvPi);
      return f;
    }
    const T sigma = saturate_t(raw_sigma);
    const T a = 1.0f / (kPi + sigma * (0.5f * kPi - 2.0f / 3.0f));
    const T b_on = sigma * a;
    // Single scattering a + b_on t.
    float t = dot(wo_, wi) - wi.z * wo_.z;
    if (t > 0.0f) t /= std::max(wi.z, wo_.z) + 1e-38f;
    const T single = a + b_on * t;
    // Multiple scattering: the energy the single-scattering lobe loses, by albedo.
    const T E_avg = a * kPi + ((2.0f * kPi - 5.6f) / 3.0f) * b_on;
    const T E_o = a * kPi + b_on * oren_nayar_G(wo_.z);
    const T E_i = a * kPi + b_on * oren_nayar_G(wi.z);
    for (int c = 0; c < 3; ++c) {
      const T w = max_by_value(b[size_t(c)], T(0.0f));
      const T rho = saturate_t(b[size_t(c)]);
      const T m = (1.0f / kPi) * rho * rho * (E_avg / (1.0f - E_avg)) / (1.0f - rho * (1.0f - E_avg)) * (1.0f - E_o);
      f[size_t(c)] = w * (wi.z * (single + m * (1.0f - E_i)));
    }
    return f;
  }

  Vec3 b_, wo_;
  float raw_sigma_;
};

}  // namespace ptir
