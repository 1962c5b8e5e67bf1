// Image metrics of the evaluation protocol (docs/method.md §7), as the peers compute them.
//
// Images are ptir::Image (float, interleaved). Masks are 1-channel images (or the
// last channel of an RGBA image, see mask_from_alpha); a pixel is foreground when
// its mask value is > 0.5 (TensoIR's gt_mask = alpha > 0.5). All functions throw
// ptir::Error on size mismatches or too few channels.
#pragma once

#include <array>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/math/vec.h"

namespace ptir::eval {

// Mean squared difference over the first `channels` channels of (masked) pixels;
// mask == nullptr: every pixel. An empty mask gives 0.
double mse(const Image& a, const Image& b, const Image* mask = nullptr, int channels = 3);

// 10 log10(peak^2 / mse); +inf for mse == 0 (identical images).
double psnr_from_mse(double mse, double peak = 1.0);
double psnr(const Image& a, const Image& b, const Image* mask = nullptr, int channels = 3);

// Mean SSIM over the first three channels (11x11 Gaussian window, sigma 1.5,
// K1 0.01, K2 0.03, data range 1, skimage's border crop): optim/losses.h ssim().
double ssim(const Image& a, const Image& b);

// Per-channel albedo scale s_c = median over the foreground pixels of every view
// of gt_c / max(pred_c, 1e-6) (PhySG/TensoIR alignment; the median of an even
// count is the mean of the two middle values, as numpy's). gt and pred: >= 3
// channels, linear; masks select the pixels. Channels with no pixel get 1.
std::array<double, 3> albedo_scale(const std::vector<const Image*>& gt, const std::vector<const Image*>& pred,
                                   const std::vector<const Image*>& masks);

// The eval's per-channel albedo scale, accumulated view by view without keeping
// images: s_c = median of gt_c / pred_c over the masked pixels where both are above
// kAlbedoScaleBlack. A black pixel on either side says nothing of the scale (no
// scale turns a non-black prediction black, or a black one into a colour): a
// metal's diffuse colour is black in the truth, and counting its pixels as ratio 0
// (25 % of the family's metal members) pulled the median down to the dielectric
// ratios' lower third. Those pixels still count in the PSNR. Channels with no
// pixel get 1.
constexpr float kAlbedoScaleBlack = 1e-4f;
struct AlbedoRatios {
  std::array<std::vector<float>, 3> ratios;
  void add(const Image& gt, const Image& pred, const Image& mask);
  std::array<double, 3> scale();
};

// Median of the values (mean of the two middle ones for an even count, as
// numpy.median); throws Error when empty. Reorders `values`.
double median(std::vector<float>& values);

// pred * s, clamped to [0, 1] (3 channels; other channels dropped).
Image apply_scale(const Image& pred, const std::array<double, 3>& s);

// Mean angle in degrees between gt and pred normals over foreground pixels where
// both are non-zero (vectors are normalised first; dot clamped to [-1, 1]).
// Foreground pixels where pred is zero (nothing rendered) count as 90 degrees.
double normal_mae_deg(const Image& gt, const Image& pred, const Image* mask);

// Roughness MSE over the whole image with the background zeroed in both images
// (first channel of each; mask selects the foreground).
double roughness_mse(const Image& gt, const Image& pred, const Image* mask);

// 1-channel mask: the image's channel `c` (default: the last channel).
Image channel_image(const Image& img, int c = -1);

// Display value of linear straight colour `rgb` with coverage `alpha`, composited
// over `background` in sRGB space (how the peers compare PNG renders):
// srgb(clamp(rgb)) * alpha + background * (1 - alpha). alpha == nullptr: opaque.
Image composite_srgb(const Image& rgb, const Image* alpha, Vec3 background = Vec3(1.0f));

// Premultiplied (associated) RGBA -> straight RGB (RGB / A where A > 1e-6, else 0).
Image unpremultiply(const Image& rgba);

// The image with every value passed through linear_to_srgb (clamped to [0, 1]); first 3 channels.
Image srgb_encode(const Image& linear);

}  // namespace ptir::eval
