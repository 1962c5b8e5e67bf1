#include "ptir/optim/pseudo_normals.h"

#include <cmath>

namespace ptir {

Image pseudo_normals(const Camera& cam, const Image& depth, const Image& opacity, int r, float min_opacity,
                     float max_relative_step) {
  Image out(cam.width, cam.height, {"X", "Y", "Z", "A"});
  auto point = [&](int x, int y) {
    Ray r = cam.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
    return r.o + depth.at(x, y, 0) * r.d;
  };
  auto solid = [&](int x, int y) { return opacity.at(x, y, 0) > min_opacity; };
  for (int y = r; y + r < cam.height; ++y)
    for (int x = r; x + r < cam.width; ++x) {
      if (!solid(x, y) || !solid(x - r, y) || !solid(x + r, y) || !solid(x, y - r) || !solid(x, y + r)) continue;
      const float dc = depth.at(x, y, 0);
      bool edge = false;
      for (auto [nx, ny] : {std::pair{x - r, y}, {x + r, y}, {x, y - r}, {x, y + r}})
        edge |= std::fabs(depth.at(nx, ny, 0) - dc) > max_relative_step * dc;
      if (edge) continue;
      Vec3 n = cross(point(x + r, y) - point(x - r, y), point(x, y + r) - point(x, y - r));
      const float len = length(n);
      if (!(len > 0.0f)) continue;
      n = n / len;
      if (dot(n, cam.generate_ray(float(x) + 0.5f, float(y) + 0.5f).d) > 0.0f) n = -n;
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = n[c];
      out.at(x, y, 3) = 1.0f;
    }
  return out;
}

double normal_consistency(const Image& nsum, const Image& pseudo, float weight, Image* d_nsum, bool per_hit,
                          float max_cos) {
  if (d_nsum) *d_nsum = Image(nsum.width, nsum.height, {"X", "Y", "Z"});
  double total = 0;
  size_t count = 0;
  for (int y = 0; y < nsum.height; ++y)
    for (int x = 0; x < nsum.width; ++x)
      if (pseudo.at(x, y, 3) > 0.0f) count++;
  if (count == 0) return 0.0;
  const float scale = weight / float(count);
  for (int y = 0; y < nsum.height; ++y)
    for (int x = 0; x < nsum.width; ++x) {
      if (!(pseudo.at(x, y, 3) > 0.0f)) continue;
      const Vec3 s(nsum.at(x, y, 0), nsum.at(x, y, 1), nsum.at(x, y, 2));
      const Vec3 p(pseudo.at(x, y, 0), pseudo.at(x, y, 1), pseudo.at(x, y, 2));
      const float len = length(s);
      if (per_hit && d_nsum && !(len > 1e-12f && dot(s, p) / len >= max_cos))
        for (int k = 0; k < 3; ++k) d_nsum->at(x, y, k) = -scale * p[k];
      if (!(len > 1e-12f)) {
        total += 1.0;
        continue;
      }
      const Vec3 n = s / len;
      const float c = dot(n, p);
      total += 1.0 - c;
      if (d_nsum && !per_hit && c < max_cos) {
        // d(1 - n.p)/ds = -(p - (n.p) n) / |s|
        const Vec3 g = (-scale / len) * (p - c * n);
        for (int k = 0; k < 3; ++k) d_nsum->at(x, y, k) = g[k];
      }
    }
  return total / double(count);
}

}  // namespace ptir
