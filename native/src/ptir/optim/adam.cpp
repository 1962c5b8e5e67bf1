#include "ptir/optim/adam.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "ptir/core/error.h"

namespace ptir {

void Adam::step(std::vector<float>& x, const std::vector<float>& g) {
  if (x.size() != m.size() || g.size() != m.size())
    throw Error("Adam: parameter/gradient size " + std::to_string(x.size()) + "/" + std::to_string(g.size()) +
                " does not match the optimiser state (" + std::to_string(m.size()) + ")");
  ++t;
  const float b1 = settings.beta1, b2 = settings.beta2, eps = settings.eps;
  const float c1 = float(1.0 - std::pow(double(b1), double(t)));
  const float c2 = float(1.0 - std::pow(double(b2), double(t)));
  const float step = lr / c1;
  const float inv_sqrt_c2 = float(1.0 / std::sqrt(double(c2)));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, x.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const float gi = g[i];
      m[i] = b1 * m[i] + (1.0f - b1) * gi;
      v[i] = b2 * v[i] + (1.0f - b2) * (gi * gi);
      x[i] -= step * m[i] / (std::sqrt(v[i]) * inv_sqrt_c2 + eps);
    }
  });
}

}  // namespace ptir
