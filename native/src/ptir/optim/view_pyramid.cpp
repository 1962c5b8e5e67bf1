#include "ptir/optim/view_pyramid.h"

#include "ptir/core/error.h"

namespace ptir {

int pyramid_factor(int width, int height, int max_pixels) {
  int f = 1;
  if (max_pixels <= 0) return f;
  while (double(width / f) * double(height / f) > double(max_pixels) && width / (2 * f) >= 1 && height / (2 * f) >= 1)
    f *= 2;
  return f;
}

}  // namespace ptir
