#include "ptir/optim/albedo_facing_prior.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace ptir {
namespace {

constexpr int kBasis = 9;            // real SH bands 0-2 (sh_basis's order: band 0 first)
constexpr double kLogFloor = 1e-4;   // log albedo's floor (the albedo is a sigmoid, never 0)
constexpr double kRidge = 1e-6;      // M's diagonal, relative: a field of one facing stays solvable

using Matrix = std::array<std::array<double, kBasis>, kBasis>;
using Vector = std::array<double, kBasis>;

// Inverts the symmetric positive (semi)definite M in place by Gauss-Jordan with a
// relative ridge; false when it is not invertible even so.
bool invert(Matrix& m) {
  double trace = 0.0;
  for (int i = 0; i < kBasis; ++i) trace += m[i][i];
  if (!(trace > 0.0)) return false;
  for (int i = 0; i < kBasis; ++i) m[i][i] += kRidge * trace / kBasis;
  Matrix inv{};
  for (int i = 0; i < kBasis; ++i) inv[i][i] = 1.0;
  for (int col = 0; col < kBasis; ++col) {
    int pivot = col;
    for (int r = col + 1; r < kBasis; ++r)
      if (std::abs(m[r][col]) > std::abs(m[pivot][col])) pivot = r;
    if (std::abs(m[pivot][col]) < 1e-300) return false;
    std::swap(m[pivot], m[col]);
    std::swap(inv[pivot], inv[col]);
    const double d = 1.0 / m[col][col];
    for (int k = 0; k < kBasis; ++k) m[col][k] *= d, inv[col][k] *= d;
    for (int r = 0; r < kBasis; ++r) {
      if (r == col || m[r][col] == 0.0) continue;
      const double f = m[r][col];
      for (int k = 0; k < kBasis; ++k) m[r][k] -= f * m[col][k], inv[r][k] -= f * inv[col][k];
    }
  }
  m = inv;
  return true;
}

}  // namespace

FacingPriorResult albedo_facing_prior(const GaussianField& f, double weight, std::vector<Vec3>* grad) {
  FacingPriorResult out;
  const size_t n = std::min(f.size(), std::min(f.albedo.size(), f.normal.size()));
  if (n == 0) return out;
  // Each Gaussian's weight: its area (the two largest axes) x opacity, normalised.
  std::vector<double> w(n, 0.0);
  double total = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Vec3 s = f.scale[i];
    const float lo = std::min(s.x, std::min(s.y, s.z));
    const double area = double(s.x) * s.y * s.z / std::max(double(lo), 1e-30);
    w[i] = std::isfinite(area) ? area * double(f.opacity[i]) : 0.0;
    total += w[i];
  }
  if (!(total > 0.0)) return out;
  // Basis values, bands 1-2 centred on their weighted means (so they carry none of the
  // mean level: with one facing they are 0, not a share of the level), the normal
  // equations M = X^T W X and X^T W l_c.
  std::vector<float> x(n * kBasis);
  Vector mean{};
  for (size_t i = 0; i < n; ++i) {
    w[i] /= total;
    float* xi = &x[i * kBasis];
    sh_basis(2, normalize(f.normal[i]), xi);
    for (int a = 1; a < kBasis; ++a) mean[a] += w[i] * xi[a];
  }
  Matrix m{};
  std::array<Vector, 3> xtl{};
  for (size_t i = 0; i < n; ++i) {
    float* xi = &x[i * kBasis];
    xi[0] = 1.0f;
    for (int a = 1; a < kBasis; ++a) xi[a] = float(xi[a] - mean[a]);
    if (w[i] == 0.0) continue;
    for (int a = 0; a < kBasis; ++a) {
      for (int b = 0; b < kBasis; ++b) m[a][b] += w[i] * xi[a] * xi[b];
      for (int c = 0; c < 3; ++c) xtl[c][a] += w[i] * xi[a] * std::log(std::max(double(f.albedo[i][c]), kLogFloor));
    }
  }
  if (!invert(m)) return out;
  // beta_c = M^-1 X^T W l_c; the bands 1-2 are penalised, and g_c = M^-1 S beta_c.
  std::array<Vector, 3> g{};
  for (int c = 0; c < 3; ++c) {
    Vector beta{};
    for (int a = 0; a < kBasis; ++a)
      for (int b = 0; b < kBasis; ++b) beta[a] += m[a][b] * xtl[c][b];
    double sq = 0.0;
    for (int k = 1; k < kBasis; ++k) sq += beta[k] * beta[k];
    out.value += 0.5 * sq;
    out.correlation[c] = std::sqrt(sq);
    for (int a = 0; a < kBasis; ++a)
      for (int k = 1; k < kBasis; ++k) g[c][a] += m[a][k] * beta[k];
  }
  if (!grad || weight == 0.0) return out;
  // dP/da_ic = w_i x_i . g_c / a_ic (zero where the log floor holds).
  for (size_t i = 0; i < n && i < grad->size(); ++i) {
    if (w[i] == 0.0) continue;
    const float* xi = &x[i * kBasis];
    for (int c = 0; c < 3; ++c) {
      const double a = f.albedo[i][c];
      if (a <= kLogFloor) continue;
      double dot = 0.0;
      for (int k = 0; k < kBasis; ++k) dot += xi[k] * g[c][k];
      (*grad)[i][c] += float(weight * w[i] * dot / a);
    }
  }
  return out;
}

}  // namespace ptir
