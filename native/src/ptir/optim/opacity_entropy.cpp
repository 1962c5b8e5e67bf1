#include "ptir/optim/opacity_entropy.h"

#include <algorithm>
#include <cmath>

namespace ptir {

double opacity_entropy(const std::vector<float>& sigma, float weight, std::vector<float>* d_sigma) {
  if (sigma.empty()) return 0.0;
  const double inv_n = 1.0 / double(sigma.size());
  double sum = 0;
  for (size_t i = 0; i < sigma.size(); ++i) {
    const double s = std::clamp(double(sigma[i]), 1e-6, 1.0 - 1e-6);
    sum += -s * std::log(s) - (1.0 - s) * std::log(1.0 - s);
    if (d_sigma) (*d_sigma)[i] += float(weight * inv_n * std::log((1.0 - s) / s));
  }
  return sum * inv_n;
}

}  // namespace ptir
