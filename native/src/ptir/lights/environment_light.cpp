#include "ptir/lights/environment_light.h"

#include <cmath>

#include "ptir/core/error.h"

namespace ptir {

Image rasterise_latlong(const EnvironmentLight& light, int w, int h) {
  constexpr double kPiD = 3.14159265358979323846;
  if (w <= 0 || h <= 0) throw Error(std::string(light.type()) + " environment: lat-long size must be positive");
  Image img(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y) {
    const double theta = kPiD * (y + 0.5) / h;  // row 0 = top = +z
    for (int x = 0; x < w; ++x) {
      const double u = (x + 0.5) / w;
      const double phi = kPiD * (1.0 - 2.0 * u);  // u = 0.5 -> +x
      Vec3 d(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)), float(std::cos(theta)));
      Vec3 L = light.eval(d);
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = L[c];
    }
  }
  return img;
}

}  // namespace ptir
