// A constant environment: the same radiance colour x strength from every
// direction (Blender's world colour, a Background node with a plain Color).
//
// Sampling: uniform over the sphere, pdf = 1 / (4 pi). (Importance by radiance
// is uniform here; pbrt's UniformInfiniteLight does the same.)
//
// As an EnvironmentLight: the parameters are the colour's RGB (strength not
// applied), raw = log(colour) (the colour is exp(raw), so it stays positive).
#pragma once

#include <string>

#include "ptir/lights/environment_light.h"
#include "ptir/math/vec.h"

namespace ptir {

class ConstantEnvironment final : public EnvironmentLight {
 public:
  // Negative channels are clamped to 0; non-finite ones or a negative strength throw Error.
  explicit ConstantEnvironment(Vec3 colour = Vec3(0.0f), float strength = 1.0f);

  Vec3 colour() const { return colour_; }
  void set_colour(Vec3 c);
  float strength() const { return strength_; }
  Vec3 radiance() const { return colour_ * strength_; }

  std::unique_ptr<EnvironmentLight> clone() const override { return std::make_unique<ConstantEnvironment>(*this); }
  const char* type() const override { return "color"; }
  std::string describe() const override;
  Vec3 eval(Vec3 d) const override;
  float pdf(Vec3 d) const override;
  // Uniform sphere from u0, u1.
  EnvLightSample sample_li(float u0, float u1, float u2) const override;
  size_t parameter_count() const override { return 3; }
  void adjoint(Vec3 d, Vec3 d_Le, float* grad) const override;
  void get_raw(float* raw) const override;
  void set_raw(const float* raw) override;
  void raw_gradient(const float* raw, const float* d_value, float* d_raw) const override;
  Image to_latlong(int w, int h) const override;

 private:
  Vec3 colour_;
  float strength_ = 1.0f;
};

}  // namespace ptir
