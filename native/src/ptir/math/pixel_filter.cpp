#include "ptir/math/pixel_filter.h"

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"

namespace ptir {

namespace {

constexpr int kCells = 2048;  // CDF cells over [0, radius]
static_assert((kCells & (kCells - 1)) == 0, "sample() needs a power of two");
constexpr double kTwoPi = 6.283185307179586;

}  // namespace

PixelFilterType parse_pixel_filter(const std::string& name) {
  if (name == "box") return PixelFilterType::Box;
  if (name == "gaussian") return PixelFilterType::Gaussian;
  if (name == "blackman_harris") return PixelFilterType::BlackmanHarris;
  throw Error("unknown pixel filter '" + name + "' (choose blackman_harris, gaussian or box)");
}

const char* pixel_filter_name(PixelFilterType type) {
  switch (type) {
    case PixelFilterType::Box: return "box";
    case PixelFilterType::Gaussian: return "gaussian";
    case PixelFilterType::BlackmanHarris: return "blackman_harris";
  }
  return "?";
}

PixelFilterSampler::PixelFilterSampler(const PixelFilter& filter) : filter_(filter) {
  if (!std::isfinite(filter.width) || filter.width < 0.0f)
    throw Error("pixel filter width must be a non-negative number of pixels, got " + std::to_string(filter.width));
  if (filter.width == 0.0f) filter_ = {PixelFilterType::Box, 1.0f};
  const float w = filter_.width;
  switch (filter_.type) {
    case PixelFilterType::Box: radius_ = 0.5f * w; return;  // sampled in closed form
    case PixelFilterType::Gaussian: radius_ = 1.5f * w; break;
    case PixelFilterType::BlackmanHarris: radius_ = w; break;
  }
  // Half-profile CDF: each cell's mass by Simpson's rule (error ~h^4, far below float).
  cdf_.assign(kCells + 1, 0.0f);
  std::vector<double> acc(kCells + 1, 0.0);
  const double h = double(radius_) / kCells;
  for (int i = 0; i < kCells; ++i) {
    double a = i * h, m = a + 0.5 * h, b = a + h;
    double mass = h / 6.0 * (profile(float(a)) + 4.0 * profile(float(m)) + profile(float(b)));
    acc[i + 1] = acc[i] + mass;
  }
  for (int i = 0; i <= kCells; ++i) cdf_[i] = float(acc[i] / acc[kCells]);
  cdf_[kCells] = 1.0f;
  guide_.assign(kCells + 1, 0);
  for (int g = 0, count = 0; g <= kCells; ++g) {
    while (count <= kCells && cdf_[count] <= float(g) / kCells) ++count;
    guide_[g] = count;
  }
}

float PixelFilterSampler::profile(float x) const {
  const double ax = std::fabs(double(x));
  if (ax > radius_) return 0.0f;
  const double w = filter_.width;
  switch (filter_.type) {
    case PixelFilterType::Box: return 1.0f;
    case PixelFilterType::Gaussian: return float(std::exp(-8.0 * ax * ax / (w * w)));
    case PixelFilterType::BlackmanHarris: {
      // The window over [-w, w]: v runs 0..2pi, its peak (v = pi) at x = 0.
      double v = kTwoPi * (x / (2.0 * w) + 0.5);
      return float(0.35875 - 0.48829 * std::cos(v) + 0.14128 * std::cos(2.0 * v) - 0.01168 * std::cos(3.0 * v));
    }
  }
  return 0.0f;
}

float PixelFilterSampler::sample(float u) const {
  if (filter_.type == PixelFilterType::Box) return (u - 0.5f) * filter_.width;
  // Mirror: u < 1/2 maps to negative offsets, u > 1/2 to positive ones.
  float a = std::fabs(2.0f * u - 1.0f);
  // The cell: how many CDF entries are <= a, minus one. With g = floor(a cells)
  // (exact: cells is a power of two), g / cells <= a < (g + 1) / cells, so the
  // count lies in [guide_[g], guide_[g + 1]]: a short scan from guide_[g] finds the
  // same cell as a binary search over the whole CDF, without its 11 unpredictable
  // branches per camera ray.
  int count = kCells + 1;  // NaN: past every entry, as the binary search gives
  if (a >= 0.0f) {
    count = guide_[std::min(int(a * float(kCells)), kCells)];
    while (count <= kCells && cdf_[count] <= a) ++count;
  }
  int i = std::clamp(count - 1, 0, kCells - 1);
  float d = cdf_[i + 1] - cdf_[i];
  float t = d > 0.0f ? std::clamp((a - cdf_[i]) / d, 0.0f, 1.0f) : 0.0f;
  float x = (float(i) + t) * (radius_ / float(kCells));
  return u < 0.5f ? -x : x;
}

float PixelFilterSampler::position(int pixel, float u) const {
  if (filter_.type == PixelFilterType::Box) return float(pixel) + 0.5f * (1.0f - filter_.width) + u * filter_.width;
  return float(pixel) + 0.5f + sample(u);
}

}  // namespace ptir
