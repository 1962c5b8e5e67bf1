#include "ptir/transport/gradients.h"

#include <algorithm>

namespace ptir {

SceneGradients SceneGradients::zeros_like(const Scene& scene) {
  SceneGradients g;
  size_t n = scene.gaussians->size();
  g.gaussian_albedo.assign(n, Vec3(0.0f));
  g.gaussian_roughness.assign(n, 0.0f);
  g.gaussian_metallic.assign(n, 0.0f);
  g.mesh_base_colour.assign(scene.meshes.size(), Vec3(0.0f));
  g.mesh_roughness.assign(scene.meshes.size(), 0.0f);
  g.mesh_metallic.assign(scene.meshes.size(), 0.0f);
  g.environment.assign(scene.environment.parameter_count(), 0.0f);
  return g;
}

namespace {

template <class T>
void zero(std::vector<T>& v) {
  std::fill(v.begin(), v.end(), T{});
}

template <class T>
void accumulate(std::vector<T>& a, const std::vector<T>& b) {
  for (size_t i = 0; i < a.size(); ++i) a[i] += b[i];
}

}  // namespace

void SceneGradients::set_zero() {
  zero(gaussian_albedo); zero(gaussian_roughness); zero(gaussian_metallic);
  zero(mesh_base_colour); zero(mesh_roughness); zero(mesh_metallic);
  zero(environment);
}

void SceneGradients::add(const SceneGradients& o) {
  accumulate(gaussian_albedo, o.gaussian_albedo);
  accumulate(gaussian_roughness, o.gaussian_roughness);
  accumulate(gaussian_metallic, o.gaussian_metallic);
  accumulate(mesh_base_colour, o.mesh_base_colour);
  accumulate(mesh_roughness, o.mesh_roughness);
  accumulate(mesh_metallic, o.mesh_metallic);
  accumulate(environment, o.environment);
}

}  // namespace ptir
