// Texture lookups as Cycles' CPU kernel does them (kernel/device/cpu/image.h:
// interp_linear / interp_closest with the periodic wrap of Repeat).
#include "ptir/material/texture.h"

#include <cmath>

#include "ptir/io/image.h"

namespace ptir {

namespace {

int wrap(int i, int n) {
  const int r = i % n;
  return r < 0 ? r + n : r;
}

}  // namespace

Vec3 Texture::rgb(Uv uv) const {
  if (width <= 0 || height <= 0) return Vec3(0.0f);
  const auto texel = [&](int x, int y) { return texels[size_t(wrap(y, height)) * size_t(width) + size_t(wrap(x, width))]; };
  // Repeat: only the fractional part matters (and big coordinates stay in int range).
  if (!std::isfinite(uv.u) || !std::isfinite(uv.v)) return Vec3(0.0f);
  uv.u -= std::floor(uv.u);
  uv.v -= std::floor(uv.v);
  Vec3 c;
  if (interpolation == TextureInterpolation::Closest) {
    c = texel(int(std::floor(uv.u * float(width))), int(std::floor(uv.v * float(height))));
  } else {
    // Texel centres sit at half-integers: the four around (u W - 1/2, v H - 1/2).
    const float x = uv.u * float(width) - 0.5f, y = uv.v * float(height) - 0.5f;
    const float fx = std::floor(x), fy = std::floor(y);
    const float tx = x - fx, ty = y - fy;
    const int ix = int(fx), iy = int(fy);
    c = (1.0f - ty) * ((1.0f - tx) * texel(ix, iy) + tx * texel(ix + 1, iy)) +
        ty * ((1.0f - tx) * texel(ix, iy + 1) + tx * texel(ix + 1, iy + 1));
  }
  if (decode_srgb_after_filter) c = Vec3(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
  return c;
}

}  // namespace ptir
