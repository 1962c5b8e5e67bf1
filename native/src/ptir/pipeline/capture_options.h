// The dataset-reading options of real captures (docs/dataset_format.md) that the
// pipeline's stages, `ptir eval` and `ptir cameras` share, and how they fill
// DatasetOptions. (The commands' switches: cli/capture_flags.h.)
#pragma once

#include <string>

#include "ptir/scene/dataset.h"

namespace ptir::pipeline {

struct CaptureOptions {
  std::string layout = "auto", images, test_list, undistort_cache, dataparser_transforms, world = "auto";
  int holdout = 8;
  int max_image_side = 800;   // --max-image-side: DatasetOptions::max_side
  bool black_background = false;
  bool ignore_exif = false;
  std::string calibration;  // --calibration: a capture calibration (scene/capture_calibration.h)
};

inline void apply_capture_options(const CaptureOptions& f, DatasetOptions& d) {
  d.layout = f.layout;
  d.images = f.images;
  d.holdout = f.holdout;
  d.max_side = f.max_image_side;
  d.test_list = f.test_list;
  d.undistort_dir = f.undistort_cache;
  d.dataparser_transforms = f.dataparser_transforms;
  d.world = f.world;
  d.black_background = f.black_background;
  d.exif_exposure = !f.ignore_exif;
  d.calibration = f.calibration;
}

}  // namespace ptir::pipeline
