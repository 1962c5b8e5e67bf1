#include "ptir/lights/env_sg.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/core/number_text.h"

namespace ptir {

namespace {

constexpr double kPiD = 3.14159265358979323846;

double softplus(double x) { return x > 30.0 ? x : std::log1p(std::exp(x)); }
double sigmoid_d(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// 1 - exp(-2 lambda), accurate for small lambda.
double one_minus_e2l(double lambda) { return -std::expm1(-2.0 * lambda); }

}  // namespace

std::vector<Vec3> fibonacci_sphere(int n) {
  std::vector<Vec3> p(size_t(std::max(n, 0)));
  const double golden = kPiD * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    double z = 1.0 - (2.0 * i + 1.0) / n;
    double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    double phi = golden * i;
    p[i] = Vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
  }
  return p;
}

SgEnvironment::SgEnvironment(int lobes, float gamma, float raw_init) : gamma_(gamma) {
  if (lobes <= 0) throw Error("SgEnvironment: needs at least one lobe");
  if (!(gamma > 0.0f)) throw Error("SgEnvironment: gamma must be positive");
  axes_ = fibonacci_sphere(lobes);
  raw_.assign(size_t(lobes), Vec3(raw_init));
  sharpness_.resize(size_t(lobes));
  for (int i = 0; i < lobes; ++i) sharpness_[i] = (i % 2 == 0) ? kSharpnessEven : kSharpnessOdd;
  update();
}

Vec3 SgEnvironment::amplitude_from_raw(Vec3 raw, float gamma) {
  Vec3 c;
  for (int k = 0; k < 3; ++k) c[k] = float(std::expm1(softplus(raw[k]) / gamma));
  return c;
}

Vec3 SgEnvironment::d_amplitude_d_raw(Vec3 raw, float gamma) {
  Vec3 d;
  for (int k = 0; k < 3; ++k) d[k] = float(std::exp(softplus(raw[k]) / gamma) * sigmoid_d(raw[k]) / gamma);
  return d;
}

double SgEnvironment::lobe_integral(float lambda) {
  return 2.0 * kPiD / lambda * one_minus_e2l(lambda);
}

void SgEnvironment::update() {
  const int n = size();
  if (int(raw_.size()) != n || int(sharpness_.size()) != n)
    throw Error("SgEnvironment: raw, axes and sharpness must have the same length");
  for (Vec3& a : axes_) a = normalize(a);
  update_amplitudes();
}

void SgEnvironment::update_amplitudes() {
  const int n = size();
  amplitude_.resize(size_t(n));
  lobe_prob_.assign(size_t(n), 0.0f);
  lobe_cdf_.assign(size_t(n) + 1, 0.0f);
  std::vector<double> energy(static_cast<size_t>(n));
  double total = 0.0;
  for (int i = 0; i < n; ++i) {
    if (!(sharpness_[i] > 0.0f)) throw Error("SgEnvironment: lobe sharpness must be positive");
    amplitude_[i] = amplitude_from_raw(raw_[i], gamma_);
    energy[i] = std::max(0.0, double(luminance(amplitude_[i]))) * lobe_integral(sharpness_[i]);
    if (!std::isfinite(energy[i])) energy[i] = 0.0;
    total += energy[i];
  }
  double acc = 0.0;
  for (int i = 0; i < n; ++i) {
    double p = total > 0.0 ? energy[i] / total : 1.0 / n;
    lobe_prob_[i] = float(p);
    acc += p;
    lobe_cdf_[i + 1] = float(acc);
  }
  lobe_cdf_[n] = 1.0f;
  // Trailing zero-probability lobes get empty intervals [1, 1): never drawn.
  for (int j = n - 1; j > 0 && lobe_prob_[j] <= 0.0f; --j) lobe_cdf_[j] = 1.0f;
}

Vec3 SgEnvironment::eval(Vec3 v) const {
  v = normalize(v);
  Vec3 L(0.0f);
  for (int i = 0; i < size(); ++i) {
    float g = std::exp(sharpness_[i] * (dot(axes_[i], v) - 1.0f));
    L += amplitude_[i] * g;
  }
  return L;
}

Vec3 SgEnvironment::d_eval_d_raw(Vec3 v, int i) const {
  v = normalize(v);
  float g = std::exp(sharpness_[i] * (dot(axes_[i], v) - 1.0f));
  return d_amplitude_d_raw(raw_[i], gamma_) * g;
}

void SgEnvironment::d_eval_d_raw(Vec3 v, std::vector<Vec3>& out) const {
  out.resize(size_t(size()));
  for (int i = 0; i < size(); ++i) out[i] = d_eval_d_raw(v, i);
}

Vec3 SgEnvironment::sample_lobe(int i, float u1, float u2) const {
  const double lambda = sharpness_[i];
  // Inverse CDF of p(mu) ~ exp(lambda (mu - 1)) on [-1, 1]:
  //   mu = 1 + ln(1 - u (1 - e^{-2 lambda})) / lambda  (u = 0 -> mu = 1).
  double u = std::clamp(double(u1), 0.0, 1.0);
  double mu = 1.0 + std::log1p(-u * one_minus_e2l(lambda)) / lambda;
  mu = std::clamp(mu, -1.0, 1.0);
  double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
  double phi = 2.0 * kPiD * double(u2);
  Frame f(axes_[i]);
  Vec3 local(float(s * std::cos(phi)), float(s * std::sin(phi)), float(mu));
  return normalize(f.to_world(local));
}

float SgEnvironment::lobe_pdf(int i, Vec3 v) const {
  v = normalize(v);
  const double lambda = sharpness_[i];
  double mu = std::clamp(double(dot(axes_[i], v)), -1.0, 1.0);
  return float(lambda * std::exp(lambda * (mu - 1.0)) / (2.0 * kPiD * one_minus_e2l(lambda)));
}

SgSample SgEnvironment::sample(float u0, float u1, float u2) const {
  SgSample s;
  const int n = size();
  float u = std::clamp(u0, 0.0f, 0.99999994f);
  // Largest i with cdf[i] <= u, skipping zero-probability lobes.
  int i = int(std::upper_bound(lobe_cdf_.begin(), lobe_cdf_.begin() + n, u) - lobe_cdf_.begin()) - 1;
  i = std::clamp(i, 0, n - 1);
  while (i > 0 && lobe_prob_[i] <= 0.0f) --i;
  s.lobe = i;
  s.wi = sample_lobe(i, u1, u2);
  s.pdf = pdf(s.wi);
  s.Li = eval(s.wi);
  return s;
}

float SgEnvironment::pdf(Vec3 v) const {
  v = normalize(v);
  double p = 0.0;
  for (int i = 0; i < size(); ++i)
    if (lobe_prob_[i] > 0.0f) p += double(lobe_prob_[i]) * lobe_pdf(i, v);
  return float(p);
}

Image SgEnvironment::to_latlong(int w, int h) const { return rasterise_latlong(*this, w, h); }

std::string SgEnvironment::describe() const { return "sg " + std::to_string(size()) + " lobes"; }

EnvLightSample SgEnvironment::sample_li(float u0, float u1, float u2) const {
  SgSample s = sample(u0, u1, u2);
  return {s.wi, s.Li, s.pdf};
}

void SgEnvironment::adjoint(Vec3 d, Vec3 d_Le, float* grad) const {
  // L's channel c depends only on x_i's channel c.
  thread_local std::vector<Vec3> d_raw;
  d_eval_d_raw(d, d_raw);
  for (size_t i = 0; i < d_raw.size(); ++i) {
    Vec3 g = d_Le * d_raw[i];
    grad[3 * i] += g.x;
    grad[3 * i + 1] += g.y;
    grad[3 * i + 2] += g.z;
  }
}

void SgEnvironment::get_raw(float* raw) const {
  for (size_t i = 0; i < raw_.size(); ++i) {
    raw[3 * i] = raw_[i].x;
    raw[3 * i + 1] = raw_[i].y;
    raw[3 * i + 2] = raw_[i].z;
  }
}

void SgEnvironment::set_raw(const float* raw) {
  for (size_t i = 0; i < raw_.size(); ++i) raw_[i] = Vec3(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);
  // Not update(): the axes are unchanged, and renormalising them again would move
  // them by an ulp per call, so a resumed optimisation (fewer calls on a fresh
  // object) would drift apart from an uninterrupted one.
  update_amplitudes();
}

void SgEnvironment::raw_gradient(const float* /*raw*/, const float* d_value, float* d_raw) const {
  // The values are the raw amplitudes themselves.
  for (size_t i = 0; i < 3 * raw_.size(); ++i) d_raw[i] = d_value[i];
}

bool SgEnvironment::parameters_json(nlohmann::ordered_json* out) const {
  using ojson = nlohmann::ordered_json;
  auto v3 = [](Vec3 v) { return ojson::array({json_number(v.x), json_number(v.y), json_number(v.z)}); };
  ojson lobes = ojson::array();
  for (int i = 0; i < size(); ++i)
    lobes.push_back(ojson{{"axis", v3(axes_[size_t(i)])},
                          {"sharpness", json_number(sharpness_[size_t(i)])},
                          {"raw", v3(raw_[size_t(i)])},
                          {"amplitude", v3(amplitude(i))}});
  *out = ojson{{"gamma", json_number(gamma_)}, {"lobes", lobes}};
  return true;
}

}  // namespace ptir
