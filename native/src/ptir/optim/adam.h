// Adam (Kingma & Ba) on one flat parameter vector, with bias correction, as
// PyTorch computes it:  m = b1 m + (1-b1) g;  v = b2 v + (1-b2) g^2;
//   x -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps).
// eps defaults to PTIR's 1e-15. Element-wise and deterministic (any thread count
// gives the same bits). The state (m, v, t) is what a checkpoint stores.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace ptir {

struct AdamSettings {
  float beta1 = 0.9f;
  float beta2 = 0.999f;
  float eps = 1e-15f;
};

class Adam {
 public:
  Adam() = default;
  Adam(size_t n, float lr, const AdamSettings& s = {}) : lr(lr), settings(s), m(n, 0.0f), v(n, 0.0f) {}

  // One step on x with gradient g (same size as x).
  void step(std::vector<float>& x, const std::vector<float>& g);

  float lr = 0.0f;
  AdamSettings settings;
  std::vector<float> m, v;
  uint64_t t = 0;  // steps taken
};

}  // namespace ptir
