#include "ptir/lights/distribution.h"

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"

namespace ptir {

namespace {
// Largest float below 1: keeps samples inside [0, 1).
constexpr float kOneMinusEps = 0.99999994f;
}  // namespace

Distribution1D::Distribution1D(const float* f, int n) {
  if (n <= 0) throw Error("Distribution1D: needs at least one bin");
  func_.resize(size_t(n));
  cdf_.resize(size_t(n) + 1);
  double sum = 0.0;
  cdf_[0] = 0.0;
  for (int i = 0; i < n; ++i) {
    float v = f[i];
    func_[i] = (std::isfinite(v) && v > 0.0f) ? v : 0.0f;
    sum += func_[i];
    cdf_[i + 1] = sum;
  }
  integral_ = sum / n;
  uniform_ = !(sum > 0.0);
  if (uniform_) {
    for (int i = 0; i <= n; ++i) cdf_[i] = double(i) / n;
  } else {
    for (int i = 1; i <= n; ++i) cdf_[i] /= sum;
  }
  cdf_[n] = 1.0;
  int G = 1;
  while (G < n) G *= 2;
  guide_.resize(size_t(G) + 1);
  for (int g = 0, count = 0; g <= G; ++g) {
    while (count < n && cdf_[count] <= double(g) / G) ++count;
    guide_[g] = count;
  }
}

int Distribution1D::find_bin(float u) const {
  // Largest i in [0, n-1] with cdf_[i] <= u. Zero-width bins are skipped: for such a
  // bin i, cdf_[i+1] == cdf_[i] <= u, so a later index wins (and cdf_[n] = 1 > u).
  // i + 1 counts the cdf_[0..n) entries <= u. With g = floor(u G), exact in double
  // for G a power of two, g / G <= u < (g + 1) / G: the count lies between
  // guide_[g] and guide_[g + 1], and a short scan from guide_[g] finds it (n / G
  // entries on average): the same bin as a binary search, with fewer
  // unpredictable branches.
  const int n = size();
  if (n == 0) return 0;
  const int G = int(guide_.size()) - 1;
  const double du = double(u);
  int count = n;  // u >= 1 or NaN: every entry (as the binary search gives)
  if (du >= 0.0 && du < 1.0) {
    // The count lies in [guide_[g], guide_[g + 1]]: a short scan, or a binary
    // search where many bins share the guide cell (a peaked map: the cells
    // left of a bright patch hold many small bins), with the same result.
    const size_t g = size_t(du * G);
    count = guide_[g];
    const int end = guide_[g + 1];
    if (end - count > 8) count = int(std::upper_bound(cdf_.begin() + count, cdf_.begin() + end, du) - cdf_.begin());
    else
      while (count < n && cdf_[count] <= du) ++count;
  } else if (du < 0.0) {
    count = 0;
  }
  return std::clamp(count - 1, 0, n - 1);
}

float Distribution1D::sample_continuous(float u, float* pdf, int* index) const {
  u = std::clamp(u, 0.0f, kOneMinusEps);
  const int n = size();
  const int i = find_bin(u);
  const double width = cdf_[i + 1] - cdf_[i];
  double du = width > 0.0 ? (double(u) - cdf_[i]) / width : 0.5;
  du = std::clamp(du, 0.0, 1.0);
  float x = float((i + du) / n);
  // Stay inside bin i (rounding could push x onto the next bin's edge).
  const float lo = float(i) / n;
  const float hi = std::nextafter(float(i + 1) / n, 0.0f);
  x = std::clamp(x, lo, std::min(hi, kOneMinusEps));
  if (pdf) *pdf = pmf(i) * n;
  if (index) *index = i;
  return x;
}

int Distribution1D::sample_discrete(float u, float* pmf_out) const {
  u = std::clamp(u, 0.0f, kOneMinusEps);
  const int i = find_bin(u);
  if (pmf_out) *pmf_out = pmf(i);
  return i;
}

float Distribution1D::pmf(int i) const {
  if (i < 0 || i >= size()) return 0.0f;
  return float(cdf_[i + 1] - cdf_[i]);
}

float Distribution1D::pdf(float x) const {
  if (!(x >= 0.0f && x < 1.0f)) return 0.0f;
  const int n = size();
  const int i = std::min(int(x * n), n - 1);
  return pmf(i) * n;
}

Distribution2D::Distribution2D(const float* f, int nx, int ny) : nx_(nx), ny_(ny) {
  if (nx <= 0 || ny <= 0) throw Error("Distribution2D: needs at least one cell");
  conditional_.reserve(size_t(ny));
  std::vector<float> row_integrals(static_cast<size_t>(ny));
  for (int y = 0; y < ny; ++y) {
    conditional_.emplace_back(f + size_t(y) * nx, nx);
    row_integrals[y] = float(conditional_.back().integral());
  }
  marginal_ = Distribution1D(row_integrals.data(), ny);
}

Sample2D Distribution2D::sample(float u0, float u1) const {
  Sample2D s;
  float pdf_y = 0, pdf_x = 0;
  s.y = marginal_.sample_continuous(u0, &pdf_y, &s.iy);
  s.x = conditional_[s.iy].sample_continuous(u1, &pdf_x, &s.ix);
  s.pdf = pdf_x * pdf_y;
  return s;
}

float Distribution2D::pdf_cell(int ix, int iy) const {
  if (ix < 0 || ix >= nx_ || iy < 0 || iy >= ny_) return 0.0f;
  return marginal_.pmf(iy) * ny_ * conditional_[iy].pmf(ix) * nx_;
}

float Distribution2D::pdf(float x, float y) const {
  if (!(x >= 0.0f && x < 1.0f && y >= 0.0f && y < 1.0f)) return 0.0f;
  const int ix = std::min(int(x * nx_), nx_ - 1);
  const int iy = std::min(int(y * ny_), ny_ - 1);
  return pdf_cell(ix, iy);
}

}  // namespace ptir
