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
//   DisneySimplified    METHOD §4's simplified Disney BRDF (paper parity, --brdf disney-simplified)
#pragma once

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

  // Cosine-weighted value f~(wo, wi).
  Vec3 eval(Vec3 wi) const {
    if (principled_) return principled_->eval(wi);
    if (v2_) return v2_->eval(wi);
    if (oren_nayar_) return oren_nayar_->eval(wi);
    if (eon_) return eon_->eval(wi);
    return disney_eval(p_, wo_, wi);
  }
  // Density of sample() over wi.
  float pdf(Vec3 wi) const {
    if (principled_) return principled_->pdf(wi);
    if (v2_) return v2_->pdf(wi);
    if (oren_nayar_) return oren_nayar_->pdf(wi);
    if (eon_) return eon_->pdf(wi);
    return disney_pdf(p_, wo_, wi);
  }
  BsdfEvalPdf eval_pdf(Vec3 wi) const {
    if (principled_) return principled_->eval_pdf(wi);
    if (v2_) return v2_->eval_pdf(wi);
    if (oren_nayar_) return oren_nayar_->eval_pdf(wi);
    if (eon_) return eon_->eval_pdf(wi);
    return disney_eval_pdf(p_, wo_, wi);
  }
  // Three uniforms: u1 picks a lobe, (u2, u3) sample it.
  BsdfSample sample(float u1, float u2, float u3) const {
    if (principled_) return principled_->sample(u1, u2, u3);
    if (v2_) return v2_->sample(u1, u2, u3);
    if (oren_nayar_) return oren_nayar_->sample(u1, u2, u3);
    if (eon_) return eon_->sample(u1, u2, u3);
    return disney_sample(p_, wo_, u1, u2, u3);
  }
  // Adds the material adjoints for the adjoint d_f of f~(wo, wi); returns f~.
  Vec3 eval_grad(Vec3 wi, Vec3 d_f, MaterialGrad& g) const {
    if (principled_) return principled_->eval_grad(wi, d_f, g);
    if (v2_) return v2_->eval_grad(wi, d_f, g);
    if (oren_nayar_) return oren_nayar_->eval_grad(wi, d_f, g);
    if (eon_) return eon_->eval_grad(wi, d_f, g);
    return disney_eval_grad(p_, wo_, wi, d_f, g);
  }

 private:
  BsdfKind kind_;
  MaterialParams p_;
  Vec3 wo_;
  std::optional<PrincipledBsdf> principled_;
  std::optional<PrincipledV2Bsdf> v2_;
  std::optional<OrenNayarBsdf> oren_nayar_;
  std::optional<OrenNayarEonBsdf> eon_;
};

}  // namespace ptir
