// Training targets rendered from the splats' own captured radiance, for the
// inversion without photos (`ptir optimize --gaussians IN.ply` with no --dataset;
// docs/relightable.md). Each view is the preview AOV (render/aov.h: the SH colours
// composited front to back by the same walk the inversion traces, so the targets
// agree with the geometry exactly; linear colour associated with its exact
// coverage as alpha).
//
// The cache is a NeRF-layout dataset folder that load_dataset reads like any other:
//   DIR/key.txt                 what the images depend on (the PLY, the cameras,
//                               the samples, the filter): a different key clears DIR
//   DIR/train/view_NNN.exr      RGBA, linear colour associated with alpha (EXR's rule)
//   DIR/transforms_train.json   per-frame pinhole intrinsics and camera-to-world
// A view whose EXR is already there (same key) is not rendered again: an
// interrupted run resumes where it stopped. Every file is written atomically.
#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/io/image.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/scene/camera.h"

namespace ptir {

struct RadianceTargetSettings {
  int spp = 4;          // filter-jittered samples per pixel (antialiased like the inversion's renders)
  PixelFilter filter;   // the inversion's pixel filter
  std::string key;      // the caller's fingerprint of the input (PLY path, size, time; options)
  // Called after each view (rendered or reused); returning false stops (cancel).
  std::function<bool(int done, int total, bool rendered)> progress;
  const std::atomic<bool>* cancel = nullptr;
};

struct RadianceTargetReport {
  int rendered = 0, reused = 0;
  bool cancelled = false;
  float max_alpha = 0.0f;  // the largest alpha (coverage) of any pixel of any view, rendered or reused
};

// Renders (or reuses) every camera's target into `dir` and writes its
// transforms_train.json last (only when every view is there). Every camera must
// have the same size. Throws ptir::Error naming the file on I/O errors.
RadianceTargetReport render_radiance_targets(const SceneAccel& accel, const std::vector<Camera>& cameras,
                                             const std::string& dir, const RadianceTargetSettings& settings);

}  // namespace ptir
