// Adjoint buffers of the differentiable scene parameters, in the units the
// renderer uses (activated values): per-Gaussian albedo, roughness, metallic; per
// mesh material base colour, roughness, metallic; the environment's learnable
// parameters (EnvironmentLight::parameter_count() values: lat-long texels
// before strength, SG raw amplitudes, or a constant's colour).
#pragma once

#include <vector>

#include "ptir/math/vec.h"
#include "ptir/scene/scene.h"

namespace ptir {

struct SceneGradients {
  std::vector<Vec3> gaussian_albedo;
  std::vector<float> gaussian_roughness;
  std::vector<float> gaussian_metallic;
  std::vector<Vec3> mesh_base_colour;
  std::vector<float> mesh_roughness;
  std::vector<float> mesh_metallic;
  std::vector<float> environment;  // EnvironmentLight::adjoint() layout

  // Zero-filled buffers sized for the scene.
  static SceneGradients zeros_like(const Scene& scene);
  void set_zero();
  // this += other (element-wise; same sizes).
  void add(const SceneGradients& other);
};

}  // namespace ptir
