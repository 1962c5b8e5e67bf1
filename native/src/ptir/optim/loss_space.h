// The space the image loss compares in (optimizer.h, "Loss space"): a linear RGBA
// render mapped to the loss's RGB, with the target standing outside the mask, and
// the map's adjoint back to the linear render.
//
// Outside the mask the target stands in for the render: the 3x3 blur and the
// 11x11 SSIM windows of pixels inside then see the target there, and no gradient
// leaks out through them -- else the silhouette's neighbours (environment seen
// past the object) are pulled toward the object's colour, which drew dark object
// outlines into the recovered environment.
//
// The sRGB curve is concave, so a noisy pixel's sRGB is on average darker than
// the sRGB of its mean: taken per pixel (Srgb) the loss reads a render with few
// samples as too dark, and the light and albedo brighten (docs/objective.md).
// SrgbBlurFirst (the default) takes the loss's 3x3 blur on the linear render and
// the curve after it, so the curve sees about 1/7 of the variance and the loss
// weights stay the render's. (The curve's tangent at the target, "srgb-tangent",
// was measured and removed: docs/inversion.md.)
#pragma once

#include "ptir/io/image.h"
#include "ptir/optim/losses.h"

namespace ptir {

enum class LossCurve { Linear, Srgb, SrgbBlurFirst };

class LossSpace {
 public:
  // target_rgb: linear RGB; mask: one channel, 0 outside. SrgbBlurFirst without the
  // loss's blur falls back to Srgb.
  LossSpace(LossCurve curve, const ImageLossSettings& loss, const Image& target_rgb, const Image& mask);

  const Image& target() const { return target_; }               // in loss space (blurred where the blur is taken here)
  const ImageLossSettings& loss() const { return loss_; }       // the blur off where it is taken here
  Image encode(const Image& render) const;                      // linear RGBA render -> loss-space RGB
  // dL/d(linear render RGB) from dL/d(loss-space image), the curve taken at `render`.
  Image adjoint(const Image& d_pred, const Image& render) const;

 private:
  float curve(float c) const;
  float slope(float c) const;
  Image blurred_linear(const Image& render) const;  // render inside the mask, target outside, blurred

  LossCurve curve_;
  ImageLossSettings loss_;
  const Image& target_rgb_;
  const Image& mask_;
  Image target_;
};

}  // namespace ptir
