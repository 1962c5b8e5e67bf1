// What a surface's BSDF reads at a path vertex, and the shared result types of
// every BSDF model (material/bsdf.h dispatches between the models).
//
// Conventions (Mitsuba 3 style): directions live in the local shading frame
// (z = n), are unit length and point away from the surface; eval returns the
// cosine-weighted value f~ = f max(n.wi, 0); sample returns weight = f~ / pdf.
#pragma once

#include "ptir/math/vec.h"

namespace ptir {

// Blender's Principled BSDF inputs that PTIR models (anisotropy, sheen, clearcoat,
// transmission and subsurface are 0). albedo is Blender's Base Color (linear RGB).
// specular and specular_tint are fixed inputs (read from Blender or the PLY, never
// optimised); the simplified Disney model ignores them.
struct MaterialParams {
  Vec3 albedo{0.5f};
  float roughness = 0.5f;
  float metallic = 0.0f;
  float specular = 0.5f;       // Blender's Specular (0.5: F0 = 0.04, eta = 1.5)
  float specular_tint = 0.0f;  // Blender's Specular Tint
};

// Adjoints of the optimised material parameters (accumulated by eval_grad).
struct MaterialGrad {
  Vec3 d_albedo;
  float d_roughness = 0;
  float d_metallic = 0;
};

struct BsdfSample {
  Vec3 wi;          // sampled incident direction (local frame)
  Vec3 weight;      // f~(wo, wi) / pdf (cosine included); zero when !valid
  float pdf = 0;    // density of wi (solid angle), = pdf(wo, wi)
  bool valid = false;
};

struct BsdfEvalPdf {
  Vec3 f;         // f~ = f max(n.wi, 0)
  float pdf = 0;  // density with which sample() draws wi
};

}  // namespace ptir
