// The pixel-filter switches every rendering command shares:
//   --pixel-filter blackman_harris|gaussian|box   --filter-width W
// (Cycles' Film > Pixel Filter; Blender's default is Blackman-Harris, 1.5 px; width 0 = the 1-px box).
#pragma once

#include <CLI/CLI.hpp>

#include "ptir/pipeline/filter_options.h"

namespace ptir::cli {

using FilterFlags = pipeline::FilterOptions;

inline void add_filter_flags(CLI::App* cmd, FilterFlags* f) {
  cmd->add_option("--pixel-filter", f->type,
                  "pixel filter: blackman_harris, gaussian or box (default: the scene's, blackman_harris as Cycles)");
  cmd->add_option("--filter-width", f->width,
                  "pixel filter width in pixels, Cycles' convention (default: the scene's, 1.5; 0 = 1-px box)");
}

// Overrides `filter` (the scene's, or the default) with the switches given.
inline void apply_filter_flags(const FilterFlags& f, const CLI::App& cmd, PixelFilter& filter) {
  pipeline::apply_filter_options(f, cmd.count("--pixel-filter") > 0, cmd.count("--filter-width") > 0, filter);
}

}  // namespace ptir::cli
