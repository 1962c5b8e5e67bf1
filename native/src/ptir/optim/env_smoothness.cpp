#include "ptir/optim/env_smoothness.h"

#include <cmath>
#include <cstddef>
#include <vector>

#include "ptir/core/error.h"

namespace ptir {

double latlong_log_dirichlet(const float* raw, int width, int height, float* d_raw, float weight) {
  if (width < 1 || height < 1) throw Error("environment smoothness: the map size must be positive");
  const double pi = 3.14159265358979323846;
  const double dphi = 2.0 * pi / width, dtheta = pi / height, norm = 1.0 / (4.0 * pi);
  auto at = [&](int x, int y, int c) { return size_t(y) * width * 3 + size_t(x) * 3 + c; };
  double e = 0.0;
  // One pair (a, b) with metric weight w: w (r_a - r_b)^2 per channel.
  auto pair = [&](size_t a, size_t b, double w) {
    for (int c = 0; c < 3; ++c) {
      const double diff = double(raw[a + c]) - double(raw[b + c]);
      e += w * diff * diff;
      if (d_raw) {
        const float g = float(2.0 * w * diff) * weight;
        d_raw[a + c] += g;
        d_raw[b + c] -= g;
      }
    }
  };
  for (int y = 0; y < height; ++y) {
    // Row pairs: neighbours along phi, sin(theta) dphi apart (u wraps).
    const double row_w = width > 1 ? norm * dtheta / (std::sin((y + 0.5) * dtheta) * dphi) : 0.0;
    for (int x = 0; x < width && width > 1; ++x) pair(at(x, y, 0), at((x + 1) % width, y, 0), row_w);
    // Column pairs: neighbours along theta, across the edge at theta = (y + 1) dtheta.
    if (y + 1 < height) {
      const double col_w = norm * std::sin((y + 1) * dtheta) * dphi / dtheta;
      for (int x = 0; x < width; ++x) pair(at(x, y, 0), at(x, y + 1, 0), col_w);
    }
  }
  return e;
}

double latlong_log_chroma_variance(const float* raw, int width, int height, float* d_raw, float weight) {
  if (width < 1 || height < 1) throw Error("environment colour prior: the map size must be positive");
  const double pi = 3.14159265358979323846;
  const double dphi = 2.0 * pi / width, dtheta = pi / height;
  const size_t n = size_t(width) * height;
  // Texel solid angles (exact for the cell between its row's edges) and chromaticities.
  std::vector<double> omega(n), q(3 * n);
  double qbar[3] = {0.0, 0.0, 0.0}, total = 0.0;
  for (int y = 0; y < height; ++y) {
    const double om = dphi * (std::cos(y * dtheta) - std::cos((y + 1) * dtheta));
    for (int x = 0; x < width; ++x) {
      const size_t t = size_t(y) * width + x;
      const float* r = raw + 3 * t;
      const double l = (double(r[0]) + double(r[1]) + double(r[2])) / 3.0;
      omega[t] = om;
      total += om;
      for (int c = 0; c < 3; ++c) {
        q[3 * t + c] = double(r[c]) - l;
        qbar[c] += om * q[3 * t + c];
      }
    }
  }
  for (double& m : qbar) m /= total;
  // C and its gradient: dC/dq_tc = 2 omega_t (q_tc - qbar_c) / 4pi (the mean's own
  // term vanishes); and dC/dr_tc = dC/dq_tc, since the three q_t - qbar sum to 0.
  double e = 0.0;
  for (size_t t = 0; t < n; ++t)
    for (int c = 0; c < 3; ++c) {
      const double dq = q[3 * t + c] - qbar[c];
      e += omega[t] * dq * dq / (4.0 * pi);
      if (d_raw) d_raw[3 * t + c] += float(2.0 * omega[t] * dq / (4.0 * pi)) * weight;
    }
  return e;
}

}  // namespace ptir
