// The pixel filter a run asks for (--pixel-filter, --filter-width; Cycles' Film >
// Pixel Filter), over the one the scene or dataset records. (The commands'
// switches: cli/filter_flags.h.)
#pragma once

#include <cmath>
#include <string>

#include "ptir/core/error.h"
#include "ptir/math/pixel_filter.h"

namespace ptir::pipeline {

struct FilterOptions {
  std::string type;
  float width = 1.5f;
};

// Overrides `filter` (the scene's, or the default) with the options given.
inline void apply_filter_options(const FilterOptions& f, bool type_given, bool width_given, PixelFilter& filter) {
  if (type_given) filter.type = parse_pixel_filter(f.type);
  if (width_given) {
    if (!(f.width >= 0.0f) || !std::isfinite(f.width))
      throw Error("--filter-width must be a non-negative number of pixels, got " + std::to_string(f.width));
    filter.width = f.width;
  }
}

}  // namespace ptir::pipeline
