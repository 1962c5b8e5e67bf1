#include "ptir/eval/tensoir_albedo.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ptir/eval/metrics.h"

namespace ptir {

namespace {
constexpr size_t kSampledViews = 20;  // compute_rescale_ratio(sampled_num=20)
float gamma_encode(float v) { return std::pow(std::max(v, 0.0f), 1.0f / 2.2f); }
}  // namespace

TensoirAlbedoScore::TensoirAlbedoScore(size_t n_views)
    : interval_(n_views < kSampledViews ? 1 : n_views / kSampledViews) {}

void TensoirAlbedoScore::add_ratios(size_t view, const Image& gt, const Image& pred, const Image& alpha) {
  if (view % interval_ != 0 || view / interval_ >= kSampledViews) return;
  for (size_t p = 0; p < alpha.pixels.size(); ++p) {
    if (alpha.pixels[p] == 0.0f) continue;
    for (int c = 0; c < 3; ++c)
      ratios_[c].push_back(gt.pixels[p * gt.channels + c] / std::max(pred.pixels[p * pred.channels + c], 1e-6f));
  }
}

std::array<double, 3> TensoirAlbedoScore::scale() const {
  std::array<double, 3> s{1.0, 1.0, 1.0};
  for (int c = 0; c < 3; ++c)
    if (!ratios_[c].empty()) {
      std::vector<float> v = ratios_[c];
      s[c] = eval::median(v);
    }
  return s;
}

void TensoirAlbedoScore::add_error(const Image& gt, const Image& pred, const Image& alpha, const std::array<double, 3>& s) {
  for (size_t p = 0; p < alpha.pixels.size(); ++p) {
    const float a = alpha.pixels[p];
    // Our albedo over white by our own coverage (TensoIR renders its albedo map on white).
    const float a_ours = pred.channels == 4 ? std::clamp(pred.pixels[p * 4 + 3], 0.0f, 1.0f) : 1.0f;
    for (int c = 0; c < 3; ++c) {
      const float g = gt.pixels[p * gt.channels + c] * a + (1.0f - a);
      const float v = std::clamp(float(s[c]) * pred.pixels[p * pred.channels + c], 0.0f, 1.0f);
      const float ours = a == 0.0f ? 1.0f : v * a_ours + (1.0f - a_ours);
      const double d = double(gamma_encode(g)) - double(gamma_encode(ours));
      sum_sq_ += d * d;
    }
    count_ += 3;
  }
}

double TensoirAlbedoScore::psnr() const {
  if (count_ == 0) return std::numeric_limits<double>::quiet_NaN();
  const double mse = sum_sq_ / double(count_);
  return mse > 0.0 ? -10.0 * std::log10(mse) : 100.0;
}

}  // namespace ptir
