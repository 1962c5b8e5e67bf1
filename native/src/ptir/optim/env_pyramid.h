// Coarse-to-fine lat-long environment (the optimiser's view of it, not a light
// model): the log radiance of every texel is
//     raw_texel = fine_texel + up(coarse)
// with `coarse` a small lat-long grid (cw x cw/2, RGB) bilinearly upsampled to the
// map (u wraps, v clamps at the poles). Both are Adam groups (parameters.h:
// Environment holds `fine`, EnvironmentCoarse holds `coarse`, starting at 0).
//
// Why: one texel of a 128x64 map receives a gradient only from the few paths that
// reach it, so per-texel steps are noisy and directions no path reaches stay at
// the initial value; a coarse texel gathers the gradients of (128/cw)^2 fine ones,
// so the light's low frequencies -- what a diffuse object's shading depends on,
// and what trades off against its albedo -- converge first and everywhere, and
// the fine texels only add detail around them.
#pragma once

#include <cstddef>
#include <vector>

namespace ptir {

class LatlongUpsampler {
 public:
  LatlongUpsampler(int coarse_width, int coarse_height, int width, int height);
  // fine[i] += up(coarse)[i] over RGB texels (both row-major, 3 floats a texel).
  void add_up(const float* coarse, float* fine) const;
  // d_coarse = up^T(d_fine) (written, not accumulated).
  void adjoint(const float* d_fine, float* d_coarse) const;
  size_t coarse_size() const { return size_t(cw_) * ch_ * 3; }
  // The four coarse texels (y * cw + x) fine texel (x, y) is interpolated from, and
  // their bilinear weights (summing to 1).
  void taps(int x, int y, int node[4], float weight[4]) const;
  int coarse_width() const { return cw_; }
  int coarse_height() const { return ch_; }

 private:
  struct Tap {
    int x0, x1, y0, y1;
    float fx, fy;
  };
  Tap tap(int x, int y) const;
  int cw_, ch_, w_, h_;
};

}  // namespace ptir
