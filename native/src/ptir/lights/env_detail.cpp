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

Image env_with_detail(const Image& learnt, const Image& seen) {
  if (learnt.channels < 3 || learnt.width < 1 || learnt.height < 1) throw Error("env_with_detail: the learnt map needs RGB");
  if (seen.channels < 4) throw Error("env_with_detail: the seen map needs its 4th channel (seen or not)");
  Image out(seen.width, seen.height, {"R", "G", "B"});
  const float sx = float(learnt.width) / float(seen.width), sy = float(learnt.height) / float(seen.height);
  for (int y = 0; y < seen.height; ++y)
    for (int x = 0; x < seen.width; ++x) {
      const bool photographed = seen.at(x, y, 3) > 0.0f;
      const float fx = (float(x) + 0.5f) * sx, fy = (float(y) + 0.5f) * sy;
      for (int c = 0; c < 3; ++c)
        out.at(x, y, c) = std::max(photographed ? seen.at(x, y, c) : bilinear(learnt, fx, fy, c), 0.0f);
    }
  return out;
}

}  // namespace ptir
