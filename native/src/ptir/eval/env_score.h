// The recovered environment against the true one (synthetic sets record it):
// a PSNR after per-channel scale alignment and a contact sheet.
//
//   both lat-long RGB in Blender's orientation; ours is sampled bilinearly at the
//   true map's texel centres
//   scale     s_c = sum_t w_t gt_c / sum_t w_t ours_c, w_t = the texel's solid angle
//             (the energy match: an inversion can only know the light up to the
//             albedo's per-channel scale)
//   display   d(x) = sRGB(x / (1 + x)) (Reinhard), so lamps and sky both count
//   PSNR      -10 log10 of the solid-angle-weighted MSE of d(s ours) vs d(gt), over the
//             sphere and over the upper hemisphere (z >= 0: the sky)
#pragma once

#include <array>
#include <string>

#include "ptir/io/image.h"

namespace ptir::eval {

struct EnvScore {
  std::array<double, 3> scale{1.0, 1.0, 1.0};
  double psnr = 0.0, psnr_upper = 0.0;
  Image sheet;  // rows: true | ours (scaled) | error heat map, display values
};

EnvScore score_environment(const Image& ours, const Image& gt);

// DIR/dataset.json's training environment (envmaps/<train_env>.exr) when the
// dataset records one and the file exists, else "".
std::string dataset_training_environment(const std::string& dataset_dir);

}  // namespace ptir::eval
