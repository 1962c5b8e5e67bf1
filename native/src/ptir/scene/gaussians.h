// The Gaussian field: activated 3DGS parameters plus the per-Gaussian material
// (shading normal, albedo, roughness, metallic) that PTIR recovers.
//
// All values are activated: scale = exp(scale_i), opacity = sigmoid(opacity),
// rotation = normalised quaternion (w, x, y, z), albedo linear RGB.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ptir/io/ply.h"
#include "ptir/math/vec.h"
#include "ptir/material/shading_model.h"

namespace ptir {

// Material values a Gaussian gets when its PLY has none (docs/method.md §6 initialisation).
constexpr float kDefaultAlbedo = 0.3f;
constexpr float kDefaultRoughness = 0.6f;
constexpr float kDefaultMetallic = 0.0f;
constexpr float kDefaultSpecular = 0.5f;      // Blender's Principled defaults
constexpr float kDefaultSpecularTint = 0.0f;

struct GaussianField {
  // Geometry (fixed during inversion).
  std::vector<Vec3> position;
  std::vector<Vec3> scale;                    // standard deviations along the local axes
  std::vector<std::array<float, 4>> rotation;  // unit quaternion w, x, y, z
  std::vector<float> opacity;                 // sigma in [0, 1]

  // Radiance (preview only): SH coefficients, (sh_degree+1)^2 per channel,
  // stored per Gaussian as sh[i * sh_stride + k * 3 + c] (k = 0 is the DC term).
  int sh_degree = 0;
  std::vector<float> sh;
  int sh_stride() const { return (sh_degree + 1) * (sh_degree + 1) * 3; }

  // Material.
  std::vector<Vec3> normal;  // unit shading normal
  std::vector<Vec3> albedo;  // linear RGB in [0, 1]
  std::vector<float> roughness;
  std::vector<float> metallic;
  // Fixed Principled inputs (PLY properties `specular`, `specular_tint`); empty
  // means Blender's defaults (0.5, 0) for every Gaussian.
  std::vector<float> specular;
  std::vector<float> specular_tint;
  SurfaceShader shader = SurfaceShader::PrincipledGGX;  // distribution of the splats' Principled BSDF
  float specular_of(size_t i) const { return specular.empty() ? kDefaultSpecular : specular[i]; }
  float specular_tint_of(size_t i) const { return specular_tint.empty() ? kDefaultSpecularTint : specular_tint[i]; }
  bool normals_from_file = false;  // false: normals are the shortest axis (see init_normals_shortest_axis)

  // The file the field came from, kept so every input property is written back unchanged.
  io::PlyFile source;
  std::string source_path;

  size_t size() const { return position.size(); }

  // Rotation matrix of Gaussian i (columns are its local axes in world space).
  Mat3 rotation_matrix(size_t i) const {
    const auto& q = rotation[i];
    return quat_to_mat3(q[0], q[1], q[2], q[3]);
  }

  // Colour of Gaussian i seen along world direction `dir` from its SH (3DGS convention:
  // 0.5 + SH(dir), clamped at 0).
  Vec3 sh_colour(size_t i, Vec3 dir) const;
};

// The most SH coefficients per channel a field holds: degree 4, as Blender 5.3's splats.
inline constexpr int kMaxShDegree = 4;
inline constexpr int kMaxShCoefficients = (kMaxShDegree + 1) * (kMaxShDegree + 1);

// The SH basis values Y_k(dir) (k < (degree+1)^2, degree <= kMaxShDegree) that sh_colour
// weighs the coefficients with: colour_c = max(0, 0.5 + sum_k Y_k sh[k*3+c]).
// (For the adjoint of the colour, render/splat_composite.)
void sh_basis(int degree, Vec3 dir, float* y);

// Sets every normal to the Gaussian's shortest axis (sign arbitrary; orient afterwards).
void init_normals_shortest_axis(GaussianField& field);

// Flips normals that point toward the field's centroid (fallback orientation when no
// camera saw a Gaussian; right for closed, roughly convex objects).
void orient_normals_away_from_centroid(GaussianField& field, const std::vector<uint8_t>* only_these = nullptr);

}  // namespace ptir
