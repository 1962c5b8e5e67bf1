#include "ptir/lights/env_constant.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ptir/core/error.h"
#include "ptir/math/sampling.h"

namespace ptir {

ConstantEnvironment::ConstantEnvironment(Vec3 colour, float strength) : strength_(strength) {
  if (!(strength >= 0.0f) || !std::isfinite(strength)) throw Error("constant environment: strength must be finite and >= 0");
  set_colour(colour);
}

void ConstantEnvironment::set_colour(Vec3 c) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(c[i])) throw Error("constant environment: colour must be finite");
  colour_ = Vec3(std::max(c.x, 0.0f), std::max(c.y, 0.0f), std::max(c.z, 0.0f));
}

std::string ConstantEnvironment::describe() const {
  char b[96];
  Vec3 L = radiance();
  std::snprintf(b, sizeof b, "color (%.4g, %.4g, %.4g)", L.x, L.y, L.z);
  return b;
}

Vec3 ConstantEnvironment::eval(Vec3 /*d*/) const { return radiance(); }

float ConstantEnvironment::pdf(Vec3 /*d*/) const { return uniform_sphere_pdf(); }

EnvLightSample ConstantEnvironment::sample_li(float u0, float u1, float /*u2*/) const {
  return {square_to_uniform_sphere(u0, u1), radiance(), uniform_sphere_pdf()};
}

void ConstantEnvironment::adjoint(Vec3 /*d*/, Vec3 d_Le, float* grad) const {
  Vec3 g = d_Le * strength_;
  grad[0] += g.x;
  grad[1] += g.y;
  grad[2] += g.z;
}

void ConstantEnvironment::get_raw(float* raw) const {
  for (int c = 0; c < 3; ++c) raw[c] = std::log(std::max(colour_[c], 1e-8f));
}

void ConstantEnvironment::set_raw(const float* raw) {
  for (int c = 0; c < 3; ++c) colour_[c] = std::exp(raw[c]);
}

void ConstantEnvironment::raw_gradient(const float* raw, const float* d_value, float* d_raw) const {
  for (int c = 0; c < 3; ++c) d_raw[c] = d_value[c] * std::exp(raw[c]);
}

Image ConstantEnvironment::to_latlong(int w, int h) const { return rasterise_latlong(*this, w, h); }

}  // namespace ptir
