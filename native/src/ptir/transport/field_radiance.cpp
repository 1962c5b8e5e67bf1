#include "ptir/transport/field_radiance.h"

#include <algorithm>
#include <cmath>

namespace ptir {

namespace {

constexpr float kShC0 = 0.28209479177387814f;

float srgb_to_linear(float c) {
  c = std::min(std::max(c, 0.0f), 1.0f);
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

}  // namespace

std::vector<Vec3> field_radiance(const GaussianField& field) {
  std::vector<Vec3> radiance;
  const size_t stride = size_t(field.sh_stride());
  if (field.sh.size() < field.size() * stride || field.size() == 0) return radiance;
  radiance.resize(field.size());
  for (size_t i = 0; i < field.size(); ++i) {
    const float* dc = field.sh.data() + i * stride;  // k = 0: the DC term, one per channel
    for (int c = 0; c < 3; ++c) radiance[i][c] = srgb_to_linear(0.5f + kShC0 * dc[c]);
  }
  return radiance;
}

}  // namespace ptir
