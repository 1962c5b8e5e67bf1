#include "ptir/lights/env_detail.h"

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"

namespace ptir {

namespace {

// Bilinear lookup of a lat-long map at texel coordinates (fx, fy) (texel centres at
// +0.5): wraps in x, clamps in y.
float bilinear(const Image& m, float fx, float fy, int c) {
  const float x = fx - 0.5f, y = std::clamp(fy - 0.5f, 0.0f, float(m.height - 1));
  const int x0 = int(std::floor(x)), y0 = int(y);
  const int y1 = std::min(y0 + 1, m.height - 1);
  const float ax = x - float(x0), ay = y - float(y0);
  auto wrap = [&](int xx) { return ((xx % m.width) + m.width) % m.width; };
  const float top = (1 - ax) * m.at(wrap(x0), y0, c) + ax * m.at(wrap(x0 + 1), y0, c);
  const float bottom = (1 - ax) * m.at(wrap(x0), y1, c) + ax * m.at(wrap(x0 + 1), y1, c);
  return (1 - ay) * top + ay * bottom;
}

}  // namespace

Image env_with_detail(const Image& learnt, const Image& start, const Image& seen) {
  if (learnt.width != start.width || learnt.height != start.height || learnt.channels < 3 || start.channels < 3)
    throw Error("env_with_detail: the learnt and the starting maps differ in size");
  if (seen.channels < 4) throw Error("env_with_detail: the seen map needs its 4th channel (seen or not)");
  Image out(seen.width, seen.height, {"R", "G", "B"});
  const float sx = float(learnt.width) / float(seen.width), sy = float(learnt.height) / float(seen.height);
  for (int y = 0; y < seen.height; ++y)
    for (int x = 0; x < seen.width; ++x) {
      const float fx = (float(x) + 0.5f) * sx, fy = (float(y) + 0.5f) * sy;
      const int X = std::min(int(fx), learnt.width - 1), Y = std::min(int(fy), learnt.height - 1);
      for (int c = 0; c < 3; ++c) {
        float v = bilinear(learnt, fx, fy, c);
        if (seen.at(x, y, 3) > 0.0f) {
          const float ratio = learnt.at(X, Y, c) / std::max(start.at(X, Y, c), 1e-6f);
          v = seen.at(x, y, c) * std::clamp(ratio, 0.25f, 4.0f);
        }
        out.at(x, y, c) = std::max(v, 0.0f);
      }
    }
  return out;
}

}  // namespace ptir
