// Per-image exposure of a capture (--learn-exposure): one learnable scalar per
// training view, held as a log-scale x_v, multiplying that view's render before
// the loss:  I'_v = s_v I_v,  s_v = exp(x_v)  (initially 1).
//
// Real photographs differ in exposure (auto exposure, changing light); without
// EXIF (dataset.h reads it when the photos carry it) a per-image scale lets the
// materials and environment explain what all views share. Its gradient comes
// from the image loss:  dL/dx_v = sum over pixels and channels of dL/dI' * I'
// (chain rule through I' = exp(x) I). The scale is only determined up to a
// common factor with albedo and light, so the mean of x over the views is held
// at 0 after every step (the views' geometric-mean exposure stays 1, the
// materials and environment carry the absolute level).
//
// The values are a parameter group (ParamKind::Exposure) so checkpoints carry
// them and their Adam state; the optimiser's step() replaces that group's
// gradient with the one accumulated here. Learning rate: lr_exposure (0.03,
// at most about 3 % of exposure per step; tests/python/test_capture_layouts.py
// recovers photos darkened to 0.6 as 0.62 in 90 iterations).
#pragma once

#include <cstddef>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/optim/parameters.h"

namespace ptir {

class ExposureGradients {
 public:
  void reset(size_t views) { d_log_scale.assign(views, 0.0); }
  // The exposure of `view` in the raw parameters (1 when p has no exposure group).
  static float scale(const Parameters& p, size_t view);
  // Multiplies the RGB of `render` (4 channels, RGBA) by `s` in place.
  static void expose(Image& render, float s);
  // Adds dL/dx_view = sum d_exposed * exposed over the RGB pixels, where d_exposed
  // (3 channels) is dL/d(exposed render) and exposed the render after expose().
  void accumulate(size_t view, const Image& d_exposed, const Image& exposed);
  // The raw gradient of the exposure group (float, same size as the group).
  std::vector<float> raw_gradient() const;
  std::vector<double> d_log_scale;
};

// Holds the mean log-scale at 0 (see above); call after each Adam step.
void centre_exposure(ParameterGroup& g);

}  // namespace ptir
