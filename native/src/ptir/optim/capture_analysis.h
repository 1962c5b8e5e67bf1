// What a real capture's photos say before any fitting (docs/captures.md, "Real
// photos"), measured against the user's trained splat rendered from each photo's
// camera (render/splat_composite.h: its display colour and coverage):
//
//   subject      "object" when the splat covers little of the photos (median share of
//                the pixels with coverage > 0.5 under object_coverage): a cleaned
//                object splat before a room; else "scene". The coverage becomes each
//                photo's mask (the object's pixels), so no stage explains the
//                background with splats, and the rest of each photo is the
//                environment seen directly: background_env.
//   photometry   per photo and channel, the gain photo / splat on the object's inner
//                pixels (the median of the pixels' log ratios). The splat is one
//                consistent radiance field, so the gains' spread over the photos is
//                the cameras' exposure and white balance: with and without the EXIF
//                exposure; EXIF is applied only where it makes the photos agree
//                better (a phone's processing often normalises brightness already).
//                Each photo's gain against the median over the photos is divided out
//                (scene/capture_calibration.h); the median itself is the global colour
//                disagreement of the splat with the photos (a grade), reported: the
//                photos rule.
//   background   the photos' pixels outside the coverage (and its 2-pixel border), by
//                direction, averaged into a lat-long map of the optimiser's size in
//                Blender's orientation; texels no photo saw filled from coarser levels
//                (push-pull). The environment's starting point, not a constraint.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/scene/capture_calibration.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

struct CaptureAnalysisSettings {
  std::string subject = "auto";   // auto, object, scene
  float object_coverage = 0.85f;  // median covered share under this: an object
  int env_width = 128, env_height = 64;
  int detail_width = 0;           // the seen background's fine map (0: ~2 photo pixels a texel, 512..2048)
  std::string exif = "auto";      // auto (as measured), on, off
  bool view_gains = true;         // divide out each photo's gain against the consensus
};

struct ViewPhotometry {
  std::string name;
  double covered = 0.0;             // share of the pixels with coverage > 0.5
  double exposure = 1.0;            // EXIF, relative to the capture's median (1: none)
  std::array<double, 3> gain{};     // photo (EXIF not applied) / splat, linear
  size_t pixels = 0;                // inner object pixels the gain was measured on
};

struct CaptureAnalysis {
  std::string subject;
  double median_covered = 0.0;
  bool exif_present = false, exif_applied = false;
  double spread_raw = 0.0, spread_exif = 0.0;  // std over photos of the mean log gain
  std::array<double, 3> colour_gain{1.0, 1.0, 1.0};  // photos / splat: the median over photos
  double psnr_splat = 0.0, psnr_graded = 0.0;  // splat vs photos (object pixels, sRGB): as is, x colour_gain
  double background_seen = 0.0;                // share of the sphere's solid angle a photo saw
  std::vector<ViewPhotometry> views;
  Image background;  // lat-long env_width x env_height (empty for a scene)
  Image seen;        // the same unfilled at the fine size, RGBA (A = 1 where seen): lights/env_detail.h
  std::vector<Image> masks;  // per view: the splat's coverage (1 channel)
};

// Called after each photo is rendered and measured (done, total).
using CaptureProgress = std::function<void(size_t done, size_t total)>;

// `data`: every photo of the capture (split "all"), read without a calibration. Each
// photo's render is made once (pass 1 keeps its coverage and a sample of its object
// pixels for pass 2).
CaptureAnalysis analyse_capture(const GaussianField& field, const Dataset& data, const CaptureAnalysisSettings& s,
                                const CaptureProgress& progress = {});

// Writes OUT_DIR/masks/<view>.png (for an object), OUT_DIR/background_env.exr,
// OUT_DIR/background_seen.exr and
// OUT_DIR/calibration.json (with the analysis as its record); returns the calibration.
CaptureCalibration write_capture_analysis(const CaptureAnalysis& a, const Dataset& data, const CaptureAnalysisSettings& s,
                                          const std::string& out_dir);

// The lines the log prints about it.
std::vector<std::string> capture_analysis_lines(const CaptureAnalysis& a);

}  // namespace ptir
