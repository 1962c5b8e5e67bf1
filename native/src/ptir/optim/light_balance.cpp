#include "ptir/optim/light_balance.h"

#include <algorithm>
#include <cmath>

#include "ptir/lights/environment.h"

namespace ptir {

namespace {

float sigmoid_of(float x) { return 1.0f / (1.0f + std::exp(-x)); }

constexpr float kAlbedoCap = 1.0f - 1e-4f;  // the shift keeps albedos below this

// The fraction of a rise by e^h that albedo a can take below the cap (1 for h <= 0).
double rise_fraction(float a, float h) {
  if (!(h > 0.0f) || !(a > 0.0f)) return 1.0;
  const double risen = double(a) * std::exp(double(h));
  if (risen <= double(kAlbedoCap)) return 1.0;
  return std::clamp((double(kAlbedoCap) - double(a)) / (double(a) * std::expm1(double(h))), 0.0, 1.0);
}

// raw' with sigmoid(raw') = sigmoid(raw) e^d, kept inside (1e-4, 1 - 1e-4).
float scaled_logit(float raw, float d) {
  const float a = std::clamp(sigmoid_of(raw) * std::exp(d), 1e-4f, kAlbedoCap);
  return std::log(a / (1.0f - a));
}

}  // namespace

bool light_balance_applies(const Parameters& p, const Scene& scene) {
  return p.find(ParamKind::GaussianAlbedo) && p.find(ParamKind::Environment) && scene.environment.as<Environment>();
}

std::array<double, 3> light_balance_derivative(const Parameters& p, const Scene& scene, const SceneGradients& g,
                                               float up_step) {
  std::array<double, 3> d = {0.0, 0.0, 0.0};
  if (!light_balance_applies(p, scene)) return d;
  // Albedo side: sum a dL/da over the learnt albedos.
  const GaussianField& f = *scene.gaussians;
  for (size_t i = 0; i < f.size() && i < g.gaussian_albedo.size(); ++i)
    for (int c = 0; c < 3; ++c)
      d[c] += double(f.albedo[i][c]) * rise_fraction(f.albedo[i][c], up_step) * double(g.gaussian_albedo[i][c]);
  if (p.find(ParamKind::MeshColour))
    for (size_t i = 0; i < scene.meshes.size() && i < g.mesh_base_colour.size(); ++i)
      for (int c = 0; c < 3; ++c) {
        const float a = scene.meshes[i].material.base_colour[c];
        d[c] += double(a) * rise_fraction(a, up_step) * double(g.mesh_base_colour[i][c]);
      }
  // Light side: minus sum E dL/dE over the texels.
  const std::vector<float>& texels = scene.environment.as<Environment>()->texels();
  for (size_t t = 0; t < texels.size() && t < g.environment.size(); ++t) d[t % 3] -= double(texels[t]) * double(g.environment[t]);
  return d;
}

std::array<double, 3> albedo_chroma_prior(const Parameters& p, const Scene& scene) {
  std::array<double, 3> sum = {0.0, 0.0, 0.0};
  size_t n = 0;
  if (p.find(ParamKind::GaussianAlbedo) && scene.gaussians) {
    const GaussianField& f = *scene.gaussians;
    for (size_t i = 0; i < f.size(); ++i, ++n)
      for (int c = 0; c < 3; ++c) sum[c] += double(f.albedo[i][c]);
  }
  if (p.find(ParamKind::MeshColour))
    for (const auto& m : scene.meshes) {
      for (int c = 0; c < 3; ++c) sum[c] += double(m.material.base_colour[c]);
      ++n;
    }
  std::array<double, 3> d = {0.0, 0.0, 0.0};
  if (n == 0) return d;
  std::array<double, 3> nu;
  for (int c = 0; c < 3; ++c) nu[c] = std::log(std::max(sum[c] / double(n), 1e-8));
  const double mean = (nu[0] + nu[1] + nu[2]) / 3.0;
  for (int c = 0; c < 3; ++c) d[c] = nu[c] - mean;
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

std::array<float, 3> neutral_light_delta(const Parameters& p) {
  // Mean log radiance per channel of each level (the coarse one adds in log space).
  std::array<double, 3> mean = {0, 0, 0};
  for (const ParameterGroup& grp : p.groups) {
    if (grp.kind != ParamKind::Environment && grp.kind != ParamKind::EnvironmentCoarse) continue;
    if (grp.raw.size() < 3) continue;
    std::array<double, 3> sum = {0, 0, 0};
    for (size_t i = 0; i < grp.raw.size(); ++i) sum[i % 3] += grp.raw[i];
    for (int c = 0; c < 3; ++c) mean[c] += sum[c] / double(grp.raw.size() / 3);
  }
  const double grey = (mean[0] + mean[1] + mean[2]) / 3.0;
  return {float(mean[0] - grey), float(mean[1] - grey), float(mean[2] - grey)};
}

}  // namespace ptir
