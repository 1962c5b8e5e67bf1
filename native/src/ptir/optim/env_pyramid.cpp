#include "ptir/optim/env_pyramid.h"

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"

namespace ptir {

LatlongUpsampler::LatlongUpsampler(int coarse_width, int coarse_height, int width, int height)
    : cw_(coarse_width), ch_(coarse_height), w_(width), h_(height) {
  if (cw_ < 1 || ch_ < 1 || w_ < 1 || h_ < 1) throw Error("environment pyramid: sizes must be positive");
}

// The fine texel centre in coarse texel coordinates, and its four neighbours.
LatlongUpsampler::Tap LatlongUpsampler::tap(int x, int y) const {
  const float u = (float(x) + 0.5f) * float(cw_) / float(w_) - 0.5f;
  const float v = std::clamp((float(y) + 0.5f) * float(ch_) / float(h_) - 0.5f, 0.0f, float(ch_ - 1));
  const int xf = int(std::floor(u)), yf = int(std::floor(v));
  Tap t;
  t.fx = u - float(xf);
  t.fy = v - float(yf);
  t.x0 = ((xf % cw_) + cw_) % cw_;
  t.x1 = (t.x0 + 1) % cw_;
  t.y0 = yf;
  t.y1 = std::min(yf + 1, ch_ - 1);
  return t;
}

void LatlongUpsampler::taps(int x, int y, int node[4], float weight[4]) const {
  const Tap t = tap(x, y);
  node[0] = t.y0 * cw_ + t.x0, weight[0] = (1 - t.fy) * (1 - t.fx);
  node[1] = t.y0 * cw_ + t.x1, weight[1] = (1 - t.fy) * t.fx;
  node[2] = t.y1 * cw_ + t.x0, weight[2] = t.fy * (1 - t.fx);
  node[3] = t.y1 * cw_ + t.x1, weight[3] = t.fy * t.fx;
}

void LatlongUpsampler::add_up(const float* coarse, float* fine) const {
  for (int y = 0; y < h_; ++y)
    for (int x = 0; x < w_; ++x) {
      const Tap t = tap(x, y);
      for (int c = 0; c < 3; ++c) {
        auto at = [&](int xi, int yi) { return coarse[(size_t(yi) * cw_ + xi) * 3 + c]; };
        fine[(size_t(y) * w_ + x) * 3 + c] += (1 - t.fy) * ((1 - t.fx) * at(t.x0, t.y0) + t.fx * at(t.x1, t.y0)) +
                                              t.fy * ((1 - t.fx) * at(t.x0, t.y1) + t.fx * at(t.x1, t.y1));
      }
    }
}

void LatlongUpsampler::adjoint(const float* d_fine, float* d_coarse) const {
  std::fill(d_coarse, d_coarse + coarse_size(), 0.0f);
  for (int y = 0; y < h_; ++y)
    for (int x = 0; x < w_; ++x) {
      const Tap t = tap(x, y);
      for (int c = 0; c < 3; ++c) {
        const float g = d_fine[(size_t(y) * w_ + x) * 3 + c];
        auto at = [&](int xi, int yi) -> float& { return d_coarse[(size_t(yi) * cw_ + xi) * 3 + c]; };
        at(t.x0, t.y0) += (1 - t.fy) * (1 - t.fx) * g;
        at(t.x1, t.y0) += (1 - t.fy) * t.fx * g;
        at(t.x0, t.y1) += t.fy * (1 - t.fx) * g;
        at(t.x1, t.y1) += t.fy * t.fx * g;
      }
    }
}

}  // namespace ptir
