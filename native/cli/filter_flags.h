// The pixel-filter switches every rendering command shares:
//   --pixel-filter blackman_harris|gaussian|box   --filter-width W
// (Cycles' Film > Pixel Filter; Blender's default is Blackman-Harris, 1.5 px; width 0 = the 1-px box).
#pragma once

#include <CLI/CLI.hpp>

#include <memory>
#include <string>

#include "ptir/core/error.h"
#include "ptir/math/pixel_filter.h"

namespace ptir::cli {

struct FilterFlags {
  std::string type;
  float width = 1.5f;
};

inline void add_filter_flags(CLI::App* cmd, FilterFlags* f) {
  cmd->add_option("--pixel-filter", f->type,
                  "pixel filter: blackman_harris, gaussian or box (default: the scene's, blackman_harris as Cycles)");
  cmd->add_option("--filter-width", f->width,
                  "pixel filter width in pixels, Cycles' convention (default: the scene's, 1.5; 0 = 1-px box)");
}

// Overrides `filter` (the scene's, or the default) with the switches given.
inline void apply_filter_flags(const FilterFlags& f, const CLI::App& cmd, PixelFilter& filter) {
  if (cmd.count("--pixel-filter")) filter.type = parse_pixel_filter(f.type);
  if (cmd.count("--filter-width")) {
    if (!(f.width >= 0.0f) || !std::isfinite(f.width))
      throw Error("--filter-width must be a non-negative number of pixels, got " + std::to_string(f.width));
    filter.width = f.width;
  }
}

}  // namespace ptir::cli
