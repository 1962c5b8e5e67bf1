// The environment ("infinite light") behind one interface: radiance arriving
// from a direction, importance sampling of directions with the density MIS
// needs, the adjoint into the model's learnable parameters, and the
// optimiser's unconstrained view of those parameters. Transport, optimiser,
// evaluation, CLI and bindings use only this; the models are
//   Environment         lat-long map (lights/environment.h)
//   SgEnvironment       spherical Gaussians (lights/env_sg.h)
//   ConstantEnvironment one colour from every direction (lights/env_constant.h)
// (pbrt's ImageInfiniteLight / UniformInfiniteLight play the same roles.)
//
// Parameters: a model exposes parameter_count() floats in the units its
// radiance is linear or natural in ("values": lat-long texels before strength,
// SG raw amplitudes, the constant's RGB before strength). adjoint() adds
// dLoss/d(value). The optimiser holds "raw" unconstrained numbers; a model maps
// raw -> value with its activation (set_raw) and chains value gradients back
// (raw_gradient). The chain is a separate step, not folded into adjoint(), so
// the per-sample sums of value gradients stay exactly what they were before
// this interface existed.
//
// The scene holds the model through SceneEnvironment (below): a copyable value
// (copies are deep), empty meaning a black environment.
#pragma once

#include <memory>
#include <string>
#include <type_traits>

#include <nlohmann/json_fwd.hpp>

#include "ptir/io/image.h"
#include "ptir/math/vec.h"

namespace ptir {

// A direction drawn from an environment.
struct EnvLightSample {
  Vec3 wi;        // unit world direction toward the environment
  Vec3 Li;        // radiance arriving from wi
  float pdf = 0;  // solid-angle density; 0 means no sample
  bool valid() const { return pdf > 0.0f; }
};

class EnvironmentLight {
 public:
  virtual ~EnvironmentLight() = default;
  virtual std::unique_ptr<EnvironmentLight> clone() const = 0;

  // The model's scene-JSON type: "latlong", "sg" or "color".
  virtual const char* type() const = 0;
  // One line for logs, e.g. "latlong 128x64", "sg 24 lobes", "color (1, 1, 1)".
  virtual std::string describe() const = 0;

  // Radiance arriving from world direction d (d need not be normalised).
  virtual Vec3 eval(Vec3 d) const = 0;
  // Solid-angle density with which sample_li() produces d.
  virtual float pdf(Vec3 d) const = 0;
  // eval(d), with *pdf = pdf(d): one lookup where a model can share it (an escaping ray needs both).
  virtual Vec3 eval_pdf(Vec3 d, float* pdf) const {
    *pdf = this->pdf(d);
    return eval(d);
  }
  // An importance-sampled direction from three uniforms (a model needing fewer
  // ignores the last ones).
  virtual EnvLightSample sample_li(float u0, float u1, float u2) const = 0;

  // Learnable parameters (see the top of this file).
  virtual size_t parameter_count() const = 0;
  // grad[k] += sum_c d_Le[c] * dL_c(d)/d(value k), for the radiance seen along d.
  virtual void adjoint(Vec3 d, Vec3 d_Le, float* grad) const = 0;
  // The optimiser's unconstrained numbers for the current values.
  virtual void get_raw(float* raw) const = 0;
  // Values from raw numbers (the activation); the sampling is rebuilt.
  virtual void set_raw(const float* raw) = 0;
  // d_raw[k] = d_value[k] * d(value k)/d(raw k) at `raw`.
  virtual void raw_gradient(const float* raw, const float* d_value, float* d_raw) const = 0;

  // The radiance as a lat-long RGB image in the Environment orientation (row 0 =
  // +z, u = 0.5 = +x). An unrotated lat-long map gives its own texels times its
  // strength at its own size; other models are rasterised at w x h (each texel at
  // its centre direction).
  virtual Image to_latlong(int w, int h) const = 0;
  // The parameters as JSON, for models the lat-long image does not carry exactly
  // (written beside env.exr as env_<type>.json); false (the default): nothing to add.
  virtual bool parameters_json(nlohmann::ordered_json* /*out*/) const { return false; }
};

// Any model's radiance rasterised to a w x h lat-long RGB image in the
// Environment orientation, each texel evaluated at its centre direction.
Image rasterise_latlong(const EnvironmentLight& light, int w, int h);

// The scene's environment: one model, or none (black). Copies are deep, so a
// copied Scene never shares a learnable environment with the original.
class SceneEnvironment {
 public:
  SceneEnvironment() = default;
  // From any model by value: scene.environment = Environment::load(...).
  template <class L, class = std::enable_if_t<std::is_base_of<EnvironmentLight, std::decay_t<L>>::value>>
  SceneEnvironment(L&& light) : light_(std::make_unique<std::decay_t<L>>(std::forward<L>(light))) {}
  explicit SceneEnvironment(std::unique_ptr<EnvironmentLight> light) : light_(std::move(light)) {}
  SceneEnvironment(const SceneEnvironment& o) : light_(o.light_ ? o.light_->clone() : nullptr) {}
  SceneEnvironment(SceneEnvironment&&) noexcept = default;
  SceneEnvironment& operator=(const SceneEnvironment& o) {
    if (this != &o) light_ = o.light_ ? o.light_->clone() : nullptr;
    return *this;
  }
  SceneEnvironment& operator=(SceneEnvironment&&) noexcept = default;

  bool present() const { return bool(light_); }
  explicit operator bool() const { return present(); }
  const EnvironmentLight* get() const { return light_.get(); }
  EnvironmentLight* get() { return light_.get(); }
  const EnvironmentLight* operator->() const { return light_.get(); }
  EnvironmentLight* operator->() { return light_.get(); }
  const EnvironmentLight& operator*() const { return *light_; }
  EnvironmentLight& operator*() { return *light_; }
  // The model as a concrete type, or nullptr (for tests and model-specific outputs).
  template <class L>
  const L* as() const { return dynamic_cast<const L*>(light_.get()); }
  template <class L>
  L* as() { return dynamic_cast<L*>(light_.get()); }

  // Black when empty.
  Vec3 eval(Vec3 d) const { return light_ ? light_->eval(d) : Vec3(0.0f); }
  float pdf(Vec3 d) const { return light_ ? light_->pdf(d) : 0.0f; }
  Vec3 eval_pdf(Vec3 d, float* pdf) const {
    *pdf = 0.0f;
    return light_ ? light_->eval_pdf(d, pdf) : Vec3(0.0f);
  }
  size_t parameter_count() const { return light_ ? light_->parameter_count() : 0; }

 private:
  std::unique_ptr<EnvironmentLight> light_;
};

}  // namespace ptir
