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
// Only albedo, roughness and metallic are optimised; the rest are fixed inputs (read
// from Blender, the scene file or the PLY). Which model reads which:
//   Principled v1 (3.x)  specular, specular_tint
//   Principled v2 (4.x+) ior, specular_ior_level, specular_tint_color, diffuse_roughness
//   simplified Disney    none of them
struct MaterialParams {
  Vec3 albedo{0.5f};
  float roughness = 0.5f;
  float metallic = 0.0f;
  float specular = 0.5f;       // v1 Specular (0.5: F0 = 0.04, eta = 1.5)
  float specular_tint = 0.0f;  // v1 Specular Tint (a float)
  float ior = 1.5f;                  // v2 IOR
  float specular_ior_level = 0.5f;   // v2 Specular IOR Level (0.5: no adjustment)
  Vec3 specular_tint_color{1.0f};    // v2 Specular Tint (a colour; on metals the F82 edge tint)
  float diffuse_roughness = 0.0f;    // v2 Diffuse Roughness (0: Lambert)
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
