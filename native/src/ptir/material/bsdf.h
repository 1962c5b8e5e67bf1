// The BSDF at a path vertex: one of the surface models PTIR knows, bound to the
// vertex's outgoing direction wo (local shading frame). The transport layer talks
// to this class only, so a further model is a new BsdfKind and a new case here.
//
//   PrincipledGGX       Cycles' Principled BSDF v1, distribution "GGX" (default)
//   PrincipledMultiGGX  the same with "Multiscatter GGX" (energy-compensated)
//   PrincipledV2GGX     Cycles' Principled BSDF v2 (Blender 4.0+), distribution "GGX"
//   PrincipledV2MultiGGX  the same with "Multiscatter GGX" (v2's default)
//   OrenNayar           Blender's Diffuse BSDF node under v1 (Blender 3.x)
//   OrenNayarEon        the same node under v2 (Blender 4.3+: energy-preserving Oren-Nayar)
//   DisneySimplified    docs/method.md §4's simplified Disney BRDF (paper parity, --brdf disney-simplified)
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

#include "ptir/material/disney_brdf.h"
#include "ptir/material/material_params.h"
#include "ptir/material/oren_nayar.h"
#include "ptir/material/oren_nayar_eon.h"
#include "ptir/material/principled_bsdf.h"
#include "ptir/material/principled_v2.h"
#include "ptir/material/shading_model.h"

namespace ptir {

enum class BsdfKind : uint8_t {
  PrincipledGGX, PrincipledMultiGGX, OrenNayar, DisneySimplified, PrincipledV2GGX, PrincipledV2MultiGGX, OrenNayarEon
};

// The kind a surface gets under the scene's model: the simplified Disney model
// replaces every surface (paper parity); otherwise each surface keeps its shader,
// in the model's version (v2: Blender 4.x/5.x, whose Diffuse BSDF node is the
// energy-preserving Oren-Nayar since 4.3; 4.0-4.2 still had v1's, not modelled).
inline BsdfKind resolve_bsdf(BsdfModel model, SurfaceShader shader) {
  if (model == BsdfModel::DisneySimplified) return BsdfKind::DisneySimplified;
  if (model == BsdfModel::PrincipledV2 && shader == SurfaceShader::Diffuse) return BsdfKind::OrenNayarEon;
  if (model == BsdfModel::PrincipledV2 && shader != SurfaceShader::Diffuse)
    return shader == SurfaceShader::PrincipledMultiGGX ? BsdfKind::PrincipledV2MultiGGX : BsdfKind::PrincipledV2GGX;
  switch (shader) {
    case SurfaceShader::PrincipledMultiGGX: return BsdfKind::PrincipledMultiGGX;
    case SurfaceShader::Diffuse: return BsdfKind::OrenNayar;
    default: return BsdfKind::PrincipledGGX;
  }
}

class Bsdf {
 public:
  // min_specular_prob: sampling only (Principled's lower bound on picking its specular lobe).
  Bsdf(BsdfKind kind, const MaterialParams& p, Vec3 wo, float min_specular_prob = kMinSpecularProb)
      : kind_(kind), p_(p), wo_(wo) {
    if (kind == BsdfKind::PrincipledGGX || kind == BsdfKind::PrincipledMultiGGX)
      principled_.emplace(p, wo, kind == BsdfKind::PrincipledMultiGGX, min_specular_prob);
    else if (kind == BsdfKind::PrincipledV2GGX || kind == BsdfKind::PrincipledV2MultiGGX)
      v2_.emplace(p, wo, kind == BsdfKind::PrincipledV2MultiGGX, min_specular_prob);
    else if (kind == BsdfKind::OrenNayar)
      oren_nayar_.emplace(p, wo);
    else if (kind == BsdfKind::OrenNayarEon)
      eon_.emplace(p, wo);
  }

  BsdfKind kind() const { return kind_; }
  // The surface's own normal ns (local frame) where the closure's normal (z) differs
  // from it (a normal map; a smooth normal tilted by the reflection correction): the
  // diffuse lobe then carries Cycles' bump shadowing term (bump_shadowing). nd: the
  // diffuse lobe's normal (local frame) where it is not z: Principled v2 gives its
  // diffuse closure the normal before the reflection correction, which only its
  // specular closures get (Cycles 4.x: maybe_ensure_valid_specular_reflection).
  void set_bump_shadowing(Vec3 ns_local, Vec3 nd_local = Vec3(0.0f, 0.0f, 1.0f)) {
    bumped_ = true;
    ns_ = ns_local;
    if (v2_ && !(nd_local.x == 0.0f && nd_local.y == 0.0f && nd_local.z == 1.0f)) {
      split_diffuse_ = true;
      diffuse_frame_ = Frame(nd_local);
    }
  }

  // Cosine-weighted value f~(wo, wi).
  Vec3 eval(Vec3 wi) const { return bumped_ ? bump_shadowed(wi, model_eval(wi)) : model_eval(wi); }
  // Density of sample() over wi.
  float pdf(Vec3 wi) const {
    if (principled_) return principled_->pdf(wi);
    if (v2_) return v2_->pdf(wi);
    if (oren_nayar_) return oren_nayar_->pdf(wi);
    if (eon_) return eon_->pdf(wi);
    return disney_pdf(p_, wo_, wi);
  }
  BsdfEvalPdf eval_pdf(Vec3 wi) const {
    BsdfEvalPdf r = model_eval_pdf(wi);
    if (bumped_) r.f = bump_shadowed(wi, r.f);
    return r;
  }
  // Three uniforms: u1 picks a lobe, (u2, u3) sample it.
  BsdfSample sample(float u1, float u2, float u3) const {
    BsdfSample s = model_sample(u1, u2, u3);
    if (bumped_ && s.valid) s.weight = bump_shadowed(s.wi, s.weight * s.pdf) / s.pdf;
    return s;
  }
  // Adds the material adjoints for the adjoint d_f of f~(wo, wi); returns f~. (With bump
  // shadowing the returned value carries it; the adjoints are the unshadowed lobes'.)
  Vec3 eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const {
    const Vec3 f = model_eval_grad(wi, d_f, g);
    return bumped_ ? bump_shadowed(wi, f) : f;
  }

  // Cycles' bump shadowing term, applied to diffuse closures where the closure's
  // normal N differs from the surface's own Ns (a normal map): 0 for light on the
  // side Ns turns away from (I, N on opposite sides of Ns), else a smooth fade.
  // Blender 3.x (Chiang et al. 2019, "Taming the Shadow Terminator"): the smooth
  // step -g^3 + g^2 + g of g = (Ns.wi) / ((N.wi)(Ns.N)), 1 on the unshadowed side.
  static float bump_shadowing(Vec3 Ns, Vec3 N, Vec3 wi) {
    const float denom = dot(N, wi) * dot(Ns, N);
    const float g = denom != 0.0f ? dot(Ns, wi) / denom : 0.0f;
    if (g >= 1.0f) return 1.0f;  // the unshadowed side
    if (g < 0.0f) return 0.0f;   // light from behind the surface
    const float g2 = g * g;
    return -g2 * g + g2 + g;  // a smooth step at the terminator
  }
  // Blender 4.x (Conty Estevez et al. 2019, "A Microfacet-Based Shadowing Function to
  // Solve the Bump Terminator Problem"; Cycles 4.5 kernel/closure/bsdf.h with the
  // material's Bump Map Correction on, its default): the GGX G1 of wi about Ns for a
  // roughness alpha^2 = min(tan^2(Ns, N) / 8, 1) that grows with the tilt.
  static float bump_shadowing_microfacet(Vec3 Ns, Vec3 N, Vec3 wi) {
    const float cos_nsi = dot(Ns, wi), cos_nsn = dot(Ns, N);
    if (cos_nsi * cos_nsn * dot(N, wi) < 0.0f) return 0.0f;  // light from behind the surface
    const float cos_i = std::fabs(cos_nsi), cos_d = std::fabs(cos_nsn);
    if (cos_d >= 1.0f || cos_i >= 1.0f) return 1.0f;
    if (cos_i < 1e-6f) return 0.0f;
    const float alpha2 = std::min(0.125f * (1.0f / (cos_d * cos_d) - 1.0f), 1.0f);
    const float lambda = 0.5f * (std::sqrt(1.0f + alpha2 * std::max(1.0f / (cos_i * cos_i) - 1.0f, 0.0f)) - 1.0f);
    return 1.0f / (1.0f + lambda);
  }

 private:
  Vec3 model_eval(Vec3 wi) const {
    if (principled_) return principled_->eval(wi);
    if (v2_) return v2_->eval(wi);
    if (oren_nayar_) return oren_nayar_->eval(wi);
    if (eon_) return eon_->eval(wi);
    return disney_eval(p_, wo_, wi);
  }
  // The diffuse lobe's part of model_eval (the simplified Disney model: none).
  Vec3 model_eval_diffuse(Vec3 wi) const {
    if (principled_) return principled_->eval_diffuse(wi);
    if (v2_) return v2_->eval_diffuse(wi);
    if (oren_nayar_) return oren_nayar_->eval(wi);
    if (eon_) return eon_->eval(wi);
    return Vec3(0.0f);
  }
  BsdfEvalPdf model_eval_pdf(Vec3 wi) const {
    if (principled_) return principled_->eval_pdf(wi);
    if (v2_) return v2_->eval_pdf(wi);
    if (oren_nayar_) return oren_nayar_->eval_pdf(wi);
    if (eon_) return eon_->eval_pdf(wi);
    return disney_eval_pdf(p_, wo_, wi);
  }
  BsdfSample model_sample(float u1, float u2, float u3) const {
    if (principled_) return principled_->sample(u1, u2, u3);
    if (v2_) return v2_->sample(u1, u2, u3);
    if (oren_nayar_) return oren_nayar_->sample(u1, u2, u3);
    if (eon_) return eon_->sample(u1, u2, u3);
    return disney_sample(p_, wo_, u1, u2, u3);
  }
  Vec3 model_eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const {
    if (principled_) return principled_->eval_grad(wi, d_f, g);
    if (v2_) return v2_->eval_grad(wi, d_f, g);
    if (oren_nayar_) return oren_nayar_->eval_grad(wi, d_f, g);
    if (eon_) return eon_->eval_grad(wi, d_f, g);
    return disney_eval_grad(p_, wo_, wi, d_f, g);
  }
  // The term of the model's Blender: 4.x for Principled v2 and its Diffuse BSDF node.
  float shadowing(Vec3 Ns, Vec3 N, Vec3 wi) const {
    return v2_ || eon_ ? bump_shadowing_microfacet(Ns, N, wi) : bump_shadowing(Ns, N, wi);
  }
  // f (the model's value at wi) with its diffuse part about its own normal and scaled
  // by the bump shadowing term.
  Vec3 bump_shadowed(Vec3 wi, Vec3 f) const {
    if (!split_diffuse_) {
      const float b = shadowing(ns_, Vec3(0.0f, 0.0f, 1.0f), wi);
      return b < 1.0f ? f - (1.0f - b) * model_eval_diffuse(wi) : f;
    }
    const float b = shadowing(ns_, diffuse_frame_.n, wi);
    const Vec3 d = b > 0.0f ? v2_->eval_diffuse_at(diffuse_frame_.to_local(wo_), diffuse_frame_.to_local(wi)) : Vec3(0.0f);
    return f - model_eval_diffuse(wi) + b * d;
  }

  BsdfKind kind_;
  bool bumped_ = false;
  Vec3 ns_{0.0f, 0.0f, 1.0f};
  bool split_diffuse_ = false;  // v2: the diffuse lobe in its own frame
  Frame diffuse_frame_;
  MaterialParams p_;
  Vec3 wo_;
  std::optional<PrincipledBsdf> principled_;
  std::optional<PrincipledV2Bsdf> v2_;
  std::optional<OrenNayarBsdf> oren_nayar_;
  std::optional<OrenNayarEonBsdf> eon_;
};

}  // namespace ptir
