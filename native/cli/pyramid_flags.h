// The resolution pyramid's switches (optim/view_pyramid.h), shared by `ptir optimize`
// (both its stages) and `ptir fit`:  --coarse-pixels N  --fine-fraction F
#pragma once

#include <CLI/CLI.hpp>

namespace ptir::cli {

inline void add_pyramid_flags(CLI::App* cmd, int* coarse_pixels, float* fine_fraction) {
  cmd->add_option("--coarse-pixels", *coarse_pixels,
                  "resolution pyramid: views larger than this many pixels are rendered reduced by a power of two to "
                  "at most that many, until the last --fine-fraction of the iterations (0: always full resolution)")
      ->capture_default_str();
  cmd->add_option("--fine-fraction", *fine_fraction,
                  "resolution pyramid: the last fraction of the iterations, at the photos' full resolution (not "
                  "given, a --budget plans it: the geometry stage's from its time, the inversion's 0.5 on real "
                  "photos with more pixels than its patches visit)")
      ->capture_default_str();
}

}  // namespace ptir::cli
