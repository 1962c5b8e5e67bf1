// The loss space's map and its adjoint (loss_space.h).
#include "ptir/optim/loss_space.h"

namespace ptir {

LossSpace::LossSpace(LossCurve curve, const ImageLossSettings& loss, const Image& target_rgb, const Image& mask)
    : curve_(curve == LossCurve::SrgbBlurFirst && !loss.binomial_filter ? LossCurve::Srgb : curve),
      loss_(loss),
      target_rgb_(target_rgb),
      mask_(mask) {
  if (curve_ == LossCurve::SrgbBlurFirst) {
    loss_.binomial_filter = false;  // taken here, before the curve
    target_ = loss.blur_target ? binomial_filter(target_rgb) : target_rgb;
  } else {
    target_ = target_rgb;
  }
  for (float& v : target_.pixels) v = this->curve(v);
}

float LossSpace::curve(float c) const { return curve_ == LossCurve::Linear ? c : srgb_encode_unclamped(c); }
float LossSpace::slope(float c) const { return curve_ == LossCurve::Linear ? 1.0f : srgb_encode_derivative(c); }

Image LossSpace::blurred_linear(const Image& render) const {
  Image lin(target_rgb_.width, target_rgb_.height, {"R", "G", "B"});
  const size_t px = size_t(lin.width) * lin.height;
  for (size_t p = 0; p < px; ++p)
    for (int c = 0; c < 3; ++c)
      lin.pixels[p * 3 + c] = mask_.pixels[p] == 0.0f ? target_rgb_.pixels[p * 3 + c] : render.pixels[p * 4 + c];
  return binomial_filter(lin);
}

Image LossSpace::encode(const Image& render) const {
  if (curve_ == LossCurve::SrgbBlurFirst) {
    Image pred = blurred_linear(render);
    for (float& v : pred.pixels) v = curve(v);
    return pred;
  }
  Image pred(target_rgb_.width, target_rgb_.height, {"R", "G", "B"});
  const size_t px = size_t(pred.width) * pred.height;
  for (size_t p = 0; p < px; ++p)
    for (int c = 0; c < 3; ++c) {
      const size_t i = p * 3 + c;
      pred.pixels[i] = mask_.pixels[p] == 0.0f ? target_.pixels[i] : curve(render.pixels[p * 4 + c]);
    }
  return pred;
}

Image LossSpace::adjoint(const Image& d_pred, const Image& render) const {
  const size_t px = size_t(target_rgb_.width) * target_rgb_.height;
  Image d_render(target_rgb_.width, target_rgb_.height, {"R", "G", "B"});
  if (curve_ == LossCurve::SrgbBlurFirst) {  // through the curve at the blurred render, then the blur's adjoint
    const Image b = blurred_linear(render);
    Image d_b(b.width, b.height, {"R", "G", "B"});
    for (size_t p = 0; p < px; ++p)
      for (int c = 0; c < 3; ++c) d_b.pixels[p * 3 + c] = d_pred.pixels[p * d_pred.channels + c] * slope(b.pixels[p * 3 + c]);
    d_render = binomial_filter_adjoint(d_b);
    for (size_t p = 0; p < px; ++p)
      if (mask_.pixels[p] == 0.0f)
        for (int c = 0; c < 3; ++c) d_render.pixels[p * 3 + c] = 0.0f;  // the target stands there: no gradient
    return d_render;
  }
  for (size_t p = 0; p < px; ++p) {
    if (mask_.pixels[p] == 0.0f) continue;  // the target stands there: no gradient
    for (int c = 0; c < 3; ++c) {
      const size_t i = p * 3 + c;
      d_render.pixels[i] = d_pred.pixels[p * d_pred.channels + c] * slope(render.pixels[p * 4 + c]);
    }
  }
  return d_render;
}

}  // namespace ptir
