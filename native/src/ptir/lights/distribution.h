// Piecewise-constant distributions for importance sampling: 1D over [0, 1) and
// 2D over [0, 1)^2 (a marginal over rows, one conditional per row), in the
// spirit of pbrt's PiecewiseConstant1D/2D (our own implementation).
//
// Conventions
// - A 1D distribution of n bins: bin i covers [i/n, (i+1)/n) and has density
//   f[i] / integral, integral = (1/n) * sum f. Negative and non-finite inputs
//   count as 0. An all-zero function falls back to uniform (density 1), so
//   sampling never fails; pdf() is always the density of what sample() draws.
// - Bins of zero weight are never drawn (also for u exactly on a CDF step).
// - The 2D distribution over (x, y) takes f[y * nx + x]; x is the fast axis.
//   Its density at (x, y) is f[iy][ix] / integral_2d (or 1 when all zero).
#pragma once

#include <vector>

namespace ptir {

class Distribution1D {
 public:
  Distribution1D() = default;
  Distribution1D(const float* f, int n);
  explicit Distribution1D(const std::vector<float>& f) : Distribution1D(f.data(), int(f.size())) {}

  int size() const { return int(func_.size()); }
  // (1/n) * sum of the (clamped) function: its integral over [0, 1). 0 if all zero.
  double integral() const { return integral_; }
  float func(int i) const { return func_[i]; }

  // Continuous sample x in [0, 1) for u in [0, 1); density *pdf, bin *index.
  float sample_continuous(float u, float* pdf = nullptr, int* index = nullptr) const;
  // Discrete sample of a bin with probability pmf(i).
  int sample_discrete(float u, float* pmf = nullptr) const;
  // Density of sample_continuous at x (0 outside [0, 1)).
  float pdf(float x) const;
  // Probability of sample_discrete returning i.
  float pmf(int i) const;

 private:
  int find_bin(float u) const;
  std::vector<float> func_;
  std::vector<double> cdf_;  // n + 1 entries, cdf_[0] = 0, cdf_[n] = 1
  // Guide table (cutpoint method): guide_[g] = how many of cdf_[0..n) are <= g / G,
  // G = guide_.size() - 1 a power of two >= n, so find_bin starts its search there.
  std::vector<int> guide_;
  double integral_ = 0.0;
  bool uniform_ = true;      // all-zero function: uniform fallback
};

struct Sample2D {
  float x = 0, y = 0;  // in [0, 1)^2
  float pdf = 0;       // density w.r.t. dx dy
  int ix = 0, iy = 0;  // the cell drawn
};

class Distribution2D {
 public:
  Distribution2D() = default;
  Distribution2D(const float* f, int nx, int ny);

  int nx() const { return nx_; }
  int ny() const { return ny_; }
  double integral() const { return marginal_.integral(); }

  Sample2D sample(float u0, float u1) const;  // u0 picks the row (y), u1 the column (x)
  float pdf(float x, float y) const;
  float pdf_cell(int ix, int iy) const;  // density inside cell (ix, iy)

 private:
  int nx_ = 0, ny_ = 0;
  std::vector<Distribution1D> conditional_;  // one per row y
  Distribution1D marginal_;                  // over rows, weights = row integrals
};

}  // namespace ptir
