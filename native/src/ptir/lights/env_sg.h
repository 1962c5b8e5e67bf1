// Spherical-Gaussian environment light (docs/method.md §5):
//   L(v) = sum_i c_i exp(lambda_i (eta_i . v - 1)),
//   c_i  = exp(softplus(x_i) / gamma) - 1          (RGB, per channel; >= 0)
// with raw amplitudes x_i (RGB) as the optimised parameters. PTIR's defaults:
// N = 24 lobes, gamma = 0.3, axes eta_i on a Fibonacci sphere, sharpness
// alternating 1.0 and 20.0 (even lobes 1, odd lobes 20), x_i initialised to -3.5.
//
// Sampling: pick lobe i with probability p_i proportional to its energy
//   E_i = luminance(c_i) * 2 pi / lambda_i * (1 - exp(-2 lambda_i))
// (the integral of the lobe over the sphere times the luminance of c_i; uniform
// over lobes if all are black), then draw a direction from that lobe's normalised
// distribution exactly: with mu = eta_i . v, mu = 1 + ln(1 - xi (1 - e^{-2 lambda})) / lambda,
// phi uniform; its solid-angle density is
//   pdf_i(v) = lambda exp(lambda (mu - 1)) / (2 pi (1 - e^{-2 lambda})).
// pdf(v) = sum_i p_i pdf_i(v) is the density of the whole mixture, which MIS must use.
//
// After changing raw(), axes() or sharpness() call update() (recomputes c_i and the
// lobe selection probabilities). Directions are world directions, z up.
//
// As an EnvironmentLight: the parameters are the raw amplitudes x_i (3 per lobe)
// and raw = value (the activation is inside L).
#pragma once

#include <vector>

#include "ptir/io/image.h"
#include "ptir/lights/environment_light.h"
#include "ptir/math/vec.h"

namespace ptir {

struct SgSample {
  Vec3 wi;        // unit world direction
  Vec3 Li;        // L(wi)
  float pdf = 0;  // mixture density (solid angle)
  int lobe = -1;  // the lobe drawn
  bool valid() const { return pdf > 0.0f; }
};

class SgEnvironment final : public EnvironmentLight {
 public:
  static constexpr int kDefaultLobes = 24;
  static constexpr float kDefaultGamma = 0.3f;
  static constexpr float kDefaultRaw = -3.5f;
  static constexpr float kSharpnessEven = 1.0f;
  static constexpr float kSharpnessOdd = 20.0f;

  // PTIR's initialisation: Fibonacci axes, alternating sharpness, raw = raw_init.
  explicit SgEnvironment(int lobes = kDefaultLobes, float gamma = kDefaultGamma,
                         float raw_init = kDefaultRaw);

  int size() const { return int(axes_.size()); }
  float gamma() const { return gamma_; }

  // Raw parameters (edit, then call update()).
  std::vector<Vec3>& raw() { return raw_; }
  const std::vector<Vec3>& raw() const { return raw_; }
  std::vector<Vec3>& axes() { return axes_; }  // unit vectors (update() renormalises)
  const std::vector<Vec3>& axes() const { return axes_; }
  std::vector<float>& sharpness() { return sharpness_; }  // lambda_i > 0
  const std::vector<float>& sharpness() const { return sharpness_; }
  void update();

  Vec3 amplitude(int i) const { return amplitude_[i]; }  // c_i
  static Vec3 amplitude_from_raw(Vec3 raw, float gamma);
  static Vec3 d_amplitude_d_raw(Vec3 raw, float gamma);   // dc/dx per channel
  // Integral over the sphere of exp(lambda (eta . v - 1)): 2 pi / lambda (1 - e^{-2 lambda}).
  static double lobe_integral(float lambda);

  Vec3 eval(Vec3 v) const override;
  // dL(v)/dx_i per channel (L's channel c depends only on x_i's channel c):
  //   dc_i/dx_i * exp(lambda_i (eta_i . v - 1)).
  Vec3 d_eval_d_raw(Vec3 v, int i) const;
  // All lobes at once; out.size() becomes size().
  void d_eval_d_raw(Vec3 v, std::vector<Vec3>& out) const;

  // Mixture sampling from three uniforms (u0 picks the lobe).
  SgSample sample(float u0, float u1, float u2) const;
  float pdf(Vec3 v) const override;
  // One lobe: exact inverse-CDF sample and its density.
  Vec3 sample_lobe(int i, float u1, float u2) const;
  float lobe_pdf(int i, Vec3 v) const;
  float lobe_probability(int i) const { return lobe_prob_[i]; }

  // Rasterises L to a w x h lat-long RGB image in the Environment orientation (row 0
  // = top = +z, u = 0.5 = +x), each texel evaluated at its centre direction.
  Image to_latlong(int w, int h) const override;

  // EnvironmentLight (sample_li is sample()).
  std::unique_ptr<EnvironmentLight> clone() const override { return std::make_unique<SgEnvironment>(*this); }
  const char* type() const override { return "sg"; }
  std::string describe() const override;
  EnvLightSample sample_li(float u0, float u1, float u2) const override;
  size_t parameter_count() const override { return 3 * raw_.size(); }
  void adjoint(Vec3 d, Vec3 d_Le, float* grad) const override;
  void get_raw(float* raw) const override;
  void set_raw(const float* raw) override;
  void raw_gradient(const float* raw, const float* d_value, float* d_raw) const override;
  // {"gamma": g, "lobes": [{"axis", "sharpness", "raw", "amplitude"}, ...]}
  bool parameters_json(nlohmann::ordered_json* out) const override;

 private:
  void update_amplitudes();  // c_i and the lobe selection (update() without renormalising axes)
  float gamma_;
  std::vector<Vec3> raw_, axes_;
  std::vector<float> sharpness_;
  std::vector<Vec3> amplitude_;
  std::vector<float> lobe_prob_, lobe_cdf_;
};

// n points on the unit sphere (golden-angle spiral, z from 1 - 1/n down to -1 + 1/n).
std::vector<Vec3> fibonacci_sphere(int n);

}  // namespace ptir
