#include "ptir/optim/light_balance.h"

#include <algorithm>
#include <cmath>

#include "ptir/lights/environment.h"

namespace ptir {

namespace {

float sigmoid_of(float x) { return 1.0f / (1.0f + std::exp(-x)); }

// raw' with sigmoid(raw') = sigmoid(raw) e^d, kept inside (1e-4, 1 - 1e-4).
float scaled_logit(float raw, float d) {
  const float a = std::clamp(sigmoid_of(raw) * std::exp(d), 1e-4f, 1.0f - 1e-4f);
  return std::log(a / (1.0f - a));
}

}  // namespace

bool light_balance_applies(const Parameters& p, const Scene& scene) {
  return p.find(ParamKind::GaussianAlbedo) && p.find(ParamKind::Environment) && scene.environment.as<Environment>();
}

std::array<double, 3> light_balance_derivative(const Parameters& p, const Scene& scene, const SceneGradients& g) {
  std::array<double, 3> d = {0.0, 0.0, 0.0};
  if (!light_balance_applies(p, scene)) return d;
  // Albedo side: sum a dL/da over the learnt albedos.
  const GaussianField& f = *scene.gaussians;
  for (size_t i = 0; i < f.size() && i < g.gaussian_albedo.size(); ++i)
    for (int c = 0; c < 3; ++c) d[c] += double(f.albedo[i][c]) * double(g.gaussian_albedo[i][c]);
  if (p.find(ParamKind::MeshColour))
    for (size_t i = 0; i < scene.meshes.size() && i < g.mesh_base_colour.size(); ++i)
      for (int c = 0; c < 3; ++c) d[c] += double(scene.meshes[i].material.base_colour[c]) * double(g.mesh_base_colour[i][c]);
  // Light side: minus sum E dL/dE over the texels.
  const std::vector<float>& texels = scene.environment.as<Environment>()->texels();
  for (size_t t = 0; t < texels.size() && t < g.environment.size(); ++t) d[t % 3] -= double(texels[t]) * double(g.environment[t]);
  return d;
}

void light_balance_shift(Parameters& p, const std::array<float, 3>& delta) {
  for (ParameterGroup& grp : p.groups) {
    if (grp.kind == ParamKind::GaussianAlbedo || grp.kind == ParamKind::MeshColour)
      for (size_t i = 0; i < grp.raw.size(); ++i) grp.raw[i] = scaled_logit(grp.raw[i], delta[i % 3]);
    else if (grp.kind == ParamKind::Environment)
      for (size_t i = 0; i < grp.raw.size(); ++i) grp.raw[i] -= delta[i % 3];
  }
}

}  // namespace ptir
