// Cycles' Principled BSDF v2 (Blender 4.0 and later, as 4.5 LTS and 5.0 evaluate it),
// opaque dielectric/metal subset: the closures and their formulas are in
// principled_v2_lobes.h; this is the BSDF bound to one vertex's wo.
//
// Sampling follows Cycles' closure pick: the two GGX lobes (metal and dielectric
// share alpha and the normal, so one visible-normal strategy serves both) with
// probability P_spec = (sw_metal + sw_dielectric) / (sw_metal + sw_dielectric +
// sw_diffuse) (Cycles' sample weights with a nominal grey base colour, principled_v2_lobes.h), else the cosine
// hemisphere. P_spec is kept within [min_specular_prob, 1 - kMinDiffuseProb] (as v1,
// principled_bsdf.h): both strategies then have density everywhere, so the
// derivative of either lobe is estimated everywhere (a pure metal's metallic
// gradient needs the diffuse lobe it would become); any bound leaves the
// expectation unchanged. Cycles then evaluates every closure (one-sample MIS with the
// mixture pdf): so do eval and pdf here.
//
// Gradients: eval_grad evaluates the same template with dual numbers (dual.h) for
// base colour, roughness and metallic; sampling decisions (P_spec, the sampled
// direction) are held fixed, as PRB does.
#pragma once

#include <optional>

#include "ptir/material/dual.h"
#include "ptir/material/material_params.h"
#include "ptir/material/principled_bsdf.h"
#include "ptir/material/principled_v2_lobes.h"

namespace ptir {

class PrincipledV2Bsdf {
 public:
  PrincipledV2Bsdf(const MaterialParams& p, Vec3 wo, bool multiscatter, float min_specular_prob = kMinSpecularProb);

  Vec3 eval(Vec3 wi) const;  // f~ = f max(n.wi, 0); zero unless n.wo > 0 and n.wi > 0
  Vec3 eval_diffuse(Vec3 wi) const;  // the diffuse base's part of eval
  // The diffuse base about another normal: wo and wi in that normal's frame (its weight stays this vertex's).
  Vec3 eval_diffuse_at(Vec3 wo_d, Vec3 wi_d) const;
  float pdf(Vec3 wi) const;  // density of sample()
  BsdfEvalPdf eval_pdf(Vec3 wi) const;
  // u1 picks the strategy, (u2, u3) sample it.
  BsdfSample sample(float u1, float u2, float u3) const;
  // Adds to g the adjoints of base colour, roughness and metallic for the adjoint d_f
  // of f~(wo, wi); returns f~.
  Vec3 eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const;

  float specular_probability() const { return p_spec_; }
  // The pick probability of the GGX lobes before the bounds.
  float cycles_specular_probability() const;

 private:
  using Grad = Dual<5>;  // d/d(base R, G, B, roughness, metallic)
  float specular_pdf(Vec3 wi) const;

  MaterialParams p_;
  Vec3 wo_;
  bool multiscatter_ = false;
  principled_v2_detail::Vertex<float> v_;
  float p_spec_ = 0.5f;
  mutable std::optional<principled_v2_detail::Vertex<Grad>> grad_vertex_;  // built by the first eval_grad
};

}  // namespace ptir
