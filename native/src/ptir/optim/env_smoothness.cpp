#include "ptir/optim/env_smoothness.h"

#include <cmath>
#include <cstddef>

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

}  // namespace ptir
