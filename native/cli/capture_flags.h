// The dataset-reading switches `optimize` and `eval` share (real captures:
// docs/dataset_format.md); what they fill: pipeline/capture_options.h.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "ptir/pipeline/capture_options.h"

namespace ptir::cli {

using CaptureFlags = pipeline::CaptureOptions;

inline void add_capture_flags(CLI::App* cmd, CaptureFlags* f) {
  cmd->add_option("--layout", f->layout, "dataset layout: auto, nerf, colmap, 3dgs, nerfstudio")->capture_default_str();
  cmd->add_option("--images", f->images, "real captures: image folder (e.g. images_4; intrinsics are scaled to it)");
  cmd->add_option("--max-image-side", f->max_image_side,
                  "real captures: photos whose long side is over this are read reduced by an integer factor "
                  "(intrinsics scaled; 0: as stored)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--holdout", f->holdout, "real captures: every Nth image (name order) is a test view (0: none)")
      ->capture_default_str();
  cmd->add_option("--test-list", f->test_list, "real captures: file of test image names, one per line (instead of --holdout)");
  cmd->add_option("--undistort-cache", f->undistort_cache,
                  "real captures: folder for the undistorted images (default DATASET/ptir_undistorted/<images>)");
  cmd->add_option("--dataparser-transforms", f->dataparser_transforms,
                  "nerfstudio: splatfacto's dataparser_transforms.json (cameras into its Gaussians' frame)");
  cmd->add_option("--world", f->world, "nerfstudio world frame: auto, data, dataparser, colmap")->capture_default_str();
  cmd->add_flag("--black-background", f->black_background, "pixels that are exactly black are background (not supervised)");
  cmd->add_flag("--ignore-exif", f->ignore_exif,
                "real captures: do not divide the photos by their EXIF exposure (ExposureTime x ISO / FNumber^2)");
  cmd->add_option("--calibration", f->calibration,
                  "real captures: a capture calibration (masks, per-photo gains, EXIF on or off), e.g. the "
                  "OUT/capture/calibration.json `ptir optimize` wrote (docs/captures.md)");
}

inline void apply_capture_flags(const CaptureFlags& f, DatasetOptions& d) { pipeline::apply_capture_options(f, d); }

}  // namespace ptir::cli
