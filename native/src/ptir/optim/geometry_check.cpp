#include "ptir/optim/geometry_check.h"

#include <algorithm>
#include <cmath>

#include "ptir/accel/scene_accel.h"
#include "ptir/render/splat_composite.h"

namespace ptir {

namespace {

// The field's linear colour over black at pixel i: its display colour (composited in display
// space, as a trainer's rasteriser does) made straight, decoded, and weighted by the coverage
// again (the preview AOV's convention, render/aov.h).
float linear_colour(const SplatImage& fwd, size_t i, int c) {
  const float o = fwd.opacity.pixels[i];
  if (!(o > 0.0f)) return 0.0f;
  return o * srgb_to_linear(std::clamp(fwd.colour.pixels[3 * i + size_t(c)] / o, 0.0f, 1.0f));
}

}  // namespace

HeldOutScore held_out_radiance_psnr(const GaussianField& field, const Dataset& test) {
  HeldOutScore s;
  if (test.size() == 0) return s;
  SceneAccel accel(field, {}, AccelSettings{});
  for (size_t v = 0; v < test.size(); ++v) {
    const SplatImage fwd = render_splat(accel, test.views[v].camera, Vec3(0.0f));
    const auto photo = test.target(v);
    const size_t n = size_t(photo->rgb.width) * size_t(photo->rgb.height);
    // The field's linear colour over black (its coverage included), the photo's on black.
    std::vector<size_t> in;
    for (size_t i = 0; i < n; ++i)
      if (!photo->has_alpha || photo->alpha.pixels[i] > 0.5f) in.push_back(i);
    std::array<double, 3> gain{1.0, 1.0, 1.0};
    for (int c = 0; c < 3; ++c) {
      double rt = 0.0, rr = 0.0;
      for (size_t i : in) {
        const double r = linear_colour(fwd, i, c);
        rt += r * double(photo->rgb.pixels[3 * i + size_t(c)]);
        rr += r * r;
      }
      if (rr > 0.0) gain[size_t(c)] = rt / rr;
    }
    double se = 0.0;
    for (size_t i : in)
      for (int c = 0; c < 3; ++c) {
        const float r = linear_colour(fwd, i, c);
        const float a = linear_to_srgb(std::clamp(float(gain[size_t(c)] * r), 0.0f, 1.0f));
        const float b = linear_to_srgb(std::clamp(photo->rgb.pixels[3 * i + size_t(c)], 0.0f, 1.0f));
        se += double(a - b) * double(a - b);
      }
    const double mse = se / double(std::max<size_t>(1, 3 * in.size()));
    s.psnr.push_back(-10.0 * std::log10(std::max(mse, 1e-12)));
  }
  for (double p : s.psnr) s.mean_psnr += p / double(s.psnr.size());
  return s;
}

}  // namespace ptir
