// The geometry stage's check on a trained splat (docs/captures.md, "Real photos"):
// how well a field's radiance shows the held-out photos, so a refinement is kept only
// where it shows them better than the splat the user brought.
//
// Per held-out view: the field's colour (render/splat_composite.h; linear, over black, as the
// preview AOV gives it) against the photo's (the calibrated linear photo), in sRGB, on the photo's mask (alpha > 0.5;
// every pixel without one). Each field gets, per view and channel, the least-squares
// gain of its linear colour to the photo's on those pixels, so a splat graded away
// from the photos (its SH colours) is judged on what its geometry can show, not on the
// grade. PSNR in sRGB over those pixels; the mean over views.
#pragma once

#include <vector>

#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

struct HeldOutScore {
  double mean_psnr = 0.0;
  std::vector<double> psnr;  // per view
};

HeldOutScore held_out_radiance_psnr(const GaussianField& field, const Dataset& test);

}  // namespace ptir
