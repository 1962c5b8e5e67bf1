// Chi-square goodness-of-fit machinery for direction samplers (pbrt-style):
// bin directions in (cos theta, phi), integrate the claimed density over every
// bin numerically, pool low-expectation bins, and turn the statistic into a
// p-value with the regularized incomplete gamma function (written here, no
// external library). Shared by test_sampling.cpp and test_brdf.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "ptir/math/vec.h"

namespace ptir::test {

constexpr double kPiD = 3.14159265358979323846;

// ---------------------------------------------------------------------------
// Regularized incomplete gamma functions (Numerical Recipes style):
// P(a, x) = gamma(a, x) / Gamma(a) by its series for x < a + 1, and
// Q(a, x) = 1 - P(a, x) by a Lentz continued fraction otherwise.

inline double gamma_p_series(double a, double x) {
  double ap = a, del = 1.0 / a, sum = del;
  for (int n = 0; n < 100000; ++n) {
    ap += 1.0;
    del *= x / ap;
    sum += del;
    if (std::fabs(del) < std::fabs(sum) * 1e-16) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

inline double gamma_q_continued_fraction(double a, double x) {
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

inline double gamma_p(double a, double x) {
  if (x <= 0.0) return 0.0;
  return x < a + 1.0 ? gamma_p_series(a, x) : 1.0 - gamma_q_continued_fraction(a, x);
}

inline double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  return x < a + 1.0 ? 1.0 - gamma_p_series(a, x) : gamma_q_continued_fraction(a, x);
}

// Survival function of the chi-square distribution: P[X > x], X ~ chi2(dof).
inline double chi2_sf(double x, double dof) { return gamma_q(0.5 * dof, 0.5 * x); }

// Per-test significance that keeps the family-wise error rate at `alpha` over n tests.
inline double sidak_significance(double alpha, int n_tests) {
  return 1.0 - std::pow(1.0 - alpha, 1.0 / n_tests);
}

// ---------------------------------------------------------------------------
// Chi-square statistic with pooling of bins whose expected count is < min_expected
// (pbrt-v3's scheme: visit bins by increasing expectation, pool the small ones
// until the pool reaches min_expected). A bin with expected count exactly zero
// but a non-zero observed count is a hard failure (p = 0).

struct Chi2Result {
  double statistic = 0;
  int dof = 0;
  double p_value = 0;
  int pooled_bins = 0;
  bool impossible_sample = false;  // observed where the density is exactly 0
  std::string summary() const {
    std::ostringstream s;
    s << "chi2=" << statistic << " dof=" << dof << " p=" << p_value << " pooled=" << pooled_bins
      << (impossible_sample ? " IMPOSSIBLE-SAMPLE" : "");
    return s.str();
  }
};

inline Chi2Result chi2_test(const std::vector<double>& observed, const std::vector<double>& expected,
                            double min_expected = 5.0) {
  Chi2Result r;
  std::vector<size_t> order(expected.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  double pool_obs = 0, pool_exp = 0;
  int dof = 0;
  for (size_t idx : order) {
    double e = expected[idx], o = observed[idx];
    if (e <= 0.0) {
      if (o > 0.0) r.impossible_sample = true;
      continue;
    }
    if (e < min_expected || (pool_exp > 0.0 && pool_exp < min_expected)) {
      pool_obs += o;
      pool_exp += e;
      ++r.pooled_bins;
    } else {
      r.statistic += (o - e) * (o - e) / e;
      ++dof;
    }
  }
  if (pool_exp > 0.0) {
    r.statistic += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
    ++dof;
  }
  r.dof = dof - 1;
  r.p_value = r.impossible_sample || r.dof < 1 ? 0.0 : chi2_sf(r.statistic, r.dof);
  return r;
}

// ---------------------------------------------------------------------------
// Binning of directions (local frame) in cos(theta) in [cos_min, cos_max] and
// phi in [0, 2 pi). Directions outside the cos range map to -1.

struct SphereBinning {
  int cos_res = 20, phi_res = 40;
  double cos_min = -1.0, cos_max = 1.0;

  int size() const { return cos_res * phi_res; }
  int index(Vec3 w) const {
    double c = std::clamp(double(w.z), -1.0, 1.0);
    if (c < cos_min || c > cos_max) return -1;
    int i = int((c - cos_min) / (cos_max - cos_min) * cos_res);
    i = std::clamp(i, 0, cos_res - 1);
    double phi = std::atan2(double(w.y), double(w.x));
    if (phi < 0) phi += 2.0 * kPiD;
    int j = std::clamp(int(phi / (2.0 * kPiD) * phi_res), 0, phi_res - 1);
    return i * phi_res + j;
  }
  double cos_lo(int i) const { return cos_min + (cos_max - cos_min) * i / cos_res; }
  double cos_hi(int i) const { return cos_min + (cos_max - cos_min) * (i + 1) / cos_res; }
};

// Numerical integration over (theta, phi) rectangles, dw = sin(theta) dtheta dphi.
// Each bin is cut into base cells of at most `base_step` radians; each cell is
// integrated with a 3x3 Gauss-Legendre rule and bisected, recursively, until its
// theta- and phi-bisections both agree with it to rel_tol (or abs_tol). Sharp
// lobes can hide between the nodes of a coarse cell, so cells within
// `peak_radius` of a known peak direction are always split down to `peak_step`
// (the caller knows where its lobe is: e.g. the mirror direction, size ~ alpha).
struct QuadratureOptions {
  double base_step = 0.1;
  double rel_tol = 1e-5;  // float densities carry ~1e-7 relative noise: stay well above it
  double abs_tol = 1e-12;
  int max_depth = 24;  // bisections
  bool has_peak = false;
  Vec3 peak;  // unit direction
  double peak_radius = 0;
  double peak_step = 0;
};

// Options for a lobe of angular width ~alpha around `peak` (GGX specular, NDF).
inline QuadratureOptions lobe_quadrature(Vec3 peak, double alpha) {
  QuadratureOptions q;
  q.has_peak = true;
  q.peak = peak;
  q.peak_radius = 6.0 * alpha + 0.01;
  q.peak_step = alpha / 4.0;
  return q;
}

namespace detail {

template <class Density>
struct CellIntegrator {
  Density& pdf;
  const QuadratureOptions& opt;

  double gl3(double t0, double t1, double p0, double p1) const {
    static const double x[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
    static const double w[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    double tm = 0.5 * (t0 + t1), th = 0.5 * (t1 - t0), pm = 0.5 * (p0 + p1), ph = 0.5 * (p1 - p0);
    double st[3], ct[3], sp[3], cp[3];
    for (int i = 0; i < 3; ++i) {
      st[i] = std::sin(tm + th * x[i]);
      ct[i] = std::cos(tm + th * x[i]);
      sp[i] = std::sin(pm + ph * x[i]);
      cp[i] = std::cos(pm + ph * x[i]);
    }
    double acc = 0;
    for (int i = 0; i < 3; ++i) {
      double row = 0;
      for (int j = 0; j < 3; ++j)
        row += w[j] * double(pdf(Vec3(float(st[i] * cp[j]), float(st[i] * sp[j]), float(ct[i]))));
      acc += w[i] * st[i] * row;  // sin(theta): the solid-angle Jacobian
    }
    return acc * th * ph;
  }
  // Angular extents of a cell: along theta, and along phi at its widest latitude.
  static double extent_theta(double t0, double t1) { return t1 - t0; }
  static double extent_phi(double t1, double p0, double p1) { return (p1 - p0) * std::sin(std::min(t1, kPiD / 2)); }
  bool must_split(double t0, double t1, double p0, double p1) const {
    if (!opt.has_peak) return false;
    double et = extent_theta(t0, t1), ep = extent_phi(t1, p0, p1);
    if (std::max(et, ep) <= opt.peak_step) return false;
    double tm = 0.5 * (t0 + t1), pm = 0.5 * (p0 + p1), st = std::sin(tm);
    double cx = st * std::cos(pm), cy = st * std::sin(pm), cz = std::cos(tm);
    double c = std::clamp(cx * opt.peak.x + cy * opt.peak.y + cz * opt.peak.z, -1.0, 1.0);
    return std::acos(c) <= opt.peak_radius + 0.5 * (et + ep);
  }
  // Estimates the cell's error by bisecting it both in theta and in phi (testing
  // one direction only is fooled by features narrow in the other), then bisects
  // across the direction that disagrees more (or, when forced near the peak,
  // across the longer angular extent) until both bisections agree with the whole.
  double adapt(double t0, double t1, double p0, double p1, double whole, int depth) const {
    double tm = 0.5 * (t0 + t1), pm = 0.5 * (p0 + p1);
    double t_lo = gl3(t0, tm, p0, p1), t_hi = gl3(tm, t1, p0, p1);
    double p_lo = gl3(t0, t1, p0, pm), p_hi = gl3(t0, t1, pm, p1);
    double err_t = std::fabs(t_lo + t_hi - whole), err_p = std::fabs(p_lo + p_hi - whole);
    double best = 0.5 * (t_lo + t_hi + p_lo + p_hi);
    if (depth >= opt.max_depth) return best;
    bool forced = must_split(t0, t1, p0, p1);
    if (!forced && std::max(err_t, err_p) <= std::max(opt.abs_tol, opt.rel_tol * std::fabs(best))) return best;
    bool along_theta = forced && std::max(err_t, err_p) <= std::max(opt.abs_tol, opt.rel_tol * std::fabs(best))
                           ? extent_theta(t0, t1) >= extent_phi(t1, p0, p1)
                           : err_t >= err_p;
    if (along_theta) return adapt(t0, tm, p0, p1, t_lo, depth + 1) + adapt(tm, t1, p0, p1, t_hi, depth + 1);
    return adapt(t0, t1, p0, pm, p_lo, depth + 1) + adapt(t0, t1, pm, p1, p_hi, depth + 1);
  }
  double integrate(double t0, double t1, double p0, double p1) const {
    int nt = std::max(1, int(std::ceil((t1 - t0) / opt.base_step)));
    int np = std::max(1, int(std::ceil((p1 - p0) / opt.base_step)));
    double acc = 0;
    for (int i = 0; i < nt; ++i)
      for (int j = 0; j < np; ++j) {
        double a0 = t0 + (t1 - t0) * i / nt, a1 = t0 + (t1 - t0) * (i + 1) / nt;
        double b0 = p0 + (p1 - p0) * j / np, b1 = p0 + (p1 - p0) * (j + 1) / np;
        acc += adapt(a0, a1, b0, b1, gl3(a0, a1, b0, b1), 0);
      }
    return acc;
  }
};

}  // namespace detail

// Integral of a density over every bin of the binning.
template <class Density>
std::vector<double> integrate_bins(const SphereBinning& b, Density&& pdf, const QuadratureOptions& opt = {}) {
  detail::CellIntegrator<std::remove_reference_t<Density>> cell{pdf, opt};
  std::vector<double> out(b.size(), 0.0);
  for (int i = 0; i < b.cos_res; ++i) {
    double t_lo = std::acos(std::clamp(b.cos_hi(i), -1.0, 1.0));
    double t_hi = std::acos(std::clamp(b.cos_lo(i), -1.0, 1.0));
    for (int j = 0; j < b.phi_res; ++j)
      out[size_t(i) * b.phi_res + j] =
          cell.integrate(t_lo, t_hi, 2.0 * kPiD * j / b.phi_res, 2.0 * kPiD * (j + 1) / b.phi_res);
  }
  return out;
}

// Integral of a scalar function over the upper hemisphere.
template <class Fn>
double integrate_hemisphere(Fn&& fn, const QuadratureOptions& opt = {}) {
  detail::CellIntegrator<std::remove_reference_t<Fn>> cell{fn, opt};
  // Four azimuthal quadrants as top-level cells (keeps the phi extent of a cell <= pi/2).
  double acc = 0;
  for (int j = 0; j < 4; ++j) acc += cell.integrate(0.0, kPiD / 2, kPiD / 2 * j, kPiD / 2 * (j + 1));
  return acc;
}

// Runs the test: `sample(k)` returns {direction, valid}; invalid samples (and valid
// ones outside the binning's cos range) go to one extra bin whose expected count
// is n (1 - sum of the bin integrals).
template <class Sampler, class Density>
Chi2Result chi2_direction_test(const SphereBinning& b, Sampler&& sample, Density&& pdf, int n_samples,
                               const QuadratureOptions& opt = {}, double* integral_out = nullptr) {
  std::vector<double> observed(b.size() + 1, 0.0);
  for (int k = 0; k < n_samples; ++k) {
    auto [w, valid] = sample(k);
    int idx = valid ? b.index(w) : -1;
    observed[idx < 0 ? b.size() : idx] += 1.0;
  }
  std::vector<double> expected = integrate_bins(b, pdf, opt);
  double integral = std::accumulate(expected.begin(), expected.end(), 0.0);
  if (integral_out) *integral_out = integral;
  for (double& e : expected) e *= n_samples;
  expected.push_back(std::max(0.0, 1.0 - integral) * n_samples);
  return chi2_test(observed, expected);
}

// Wilson-Hilferty normal deviate of the chi-square statistic (bins with expected
// count < 5 are pooled). |z| < 4 is a pass (p ~ 3e-5 one-sided).
inline double chi2_z(const std::vector<double>& prob, const std::vector<int>& counts, int n, double* chi2_out = nullptr) {
  double chi2 = 0.0, pooled_e = 0.0, pooled_o = 0.0;
  int dof = -1;
  for (size_t i = 0; i < prob.size(); ++i) {
    double e = prob[i] * n;
    if (e < 5.0) {
      pooled_e += e;
      pooled_o += counts[i];
      continue;
    }
    chi2 += (counts[i] - e) * (counts[i] - e) / e;
    ++dof;
  }
  if (pooled_e > 0.0) {
    chi2 += (pooled_o - pooled_e) * (pooled_o - pooled_e) / std::max(pooled_e, 1e-9);
    ++dof;
  }
  if (chi2_out) *chi2_out = chi2;
  double k = std::max(dof, 1);
  return (std::cbrt(chi2 / k) - (1.0 - 2.0 / (9.0 * k))) / std::sqrt(2.0 / (9.0 * k));
}

}  // namespace ptir::test
