// Albedo PSNR exactly as TensoIR's published evaluation computes it
// (Haian-Jin/TensoIR, renderer.py: compute_rescale_ratio and evaluation_iter_TensoIR),
// so our numbers sit beside the peers' tables. Documented in docs/evaluation.md.
//
//   mask      ground-truth alpha != 0 (every pixel the object touches)
//   scale     s_c = median over the mask pixels of gt_c / max(pred_c, 1e-6), linear,
//             over 20 test views sampled at interval N / 20 (all views when N < 20;
//             TensoIR's interval is 0 there, a bug we do not copy)
//   aligned   clamp(s pred, 0, 1) over white by our coverage (pred's alpha: TensoIR's
//             albedo map is rendered on white) on the mask, 1 (white) elsewhere
//   gt        the straight albedo composited over white by its alpha, gt a + (1 - a)
//   PSNR      both raised to 1/2.2 (TensoIR's gamma, not the sRGB curve); one MSE over
//             every pixel of every test view (not a mean of per-view PSNRs)
// The background is white in both, so it counts as perfect: this PSNR is higher than
// our foreground-only albedo_psnr for the same result.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "ptir/io/image.h"

namespace ptir {

class TensoirAlbedoScore {
 public:
  explicit TensoirAlbedoScore(size_t n_views);
  // First pass, every view: gt albedo (linear RGB, straight), our albedo (RGB), gt alpha.
  void add_ratios(size_t view, const Image& gt, const Image& pred, const Image& alpha);
  // The per-channel scale (after every add_ratios).
  std::array<double, 3> scale() const;
  // Second pass, every view, with the scale.
  void add_error(const Image& gt, const Image& pred, const Image& alpha, const std::array<double, 3>& s);
  double psnr() const;  // -10 log10(MSE); NaN before any add_error

 private:
  size_t interval_;
  std::array<std::vector<float>, 3> ratios_;
  double sum_sq_ = 0.0;
  size_t count_ = 0;
};

}  // namespace ptir
