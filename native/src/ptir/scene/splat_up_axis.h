// The up axis of a splat PLY: which world direction is "up" for the object it
// holds (the PLY-only path's orbit and every picture of it; docs/relightable.md).
//
// A trainer's PLY lives in its capture's frame (COLMAP's: often -y up, or tilted),
// not in Blender's +z-up one. The rule, first source that answers:
//   1. --up (flag): x|y|z|-x|-y|-z or "X,Y,Z".
//   2. --cameras (a 3DGS cameras.json): the mean of the cameras' up vectors (a
//      photographer holds the camera level), when they agree (|mean| >= 0.5).
//   3. The SH cue (SH degree >= 1): the view-dependent radiance was fitted from
//      the capture's cameras only. Degree 1 makes a splat's colour change by
//      b . d along the view direction d; b grows along the directions the
//      cameras' views spread over (an orbit: around the object, a narrower band
//      of elevations), so the axis with the least degree-1 energy
//      M = sum_i w_i sum_c b_ic b_ic^T (opacity-weighted) is the orbit's axis.
//      Its sign: the energy of all bands, sum_i w_i |SH_i(d) - DC_i|^2, is
//      larger in the directions the views saw the splats along (camera to splat:
//      downwards for cameras above), so up is the axis whose hemisphere holds
//      less of it. Used when the axis is clear (1 - lambda_min / lambda_mid >=
//      0.25) and the hemispheres differ (|first moment| >= 0.05); see
//      docs/relightable.md for the measured values.
//   4. The file's convention, where the data says nothing: a PLY with PTIR's
//      material properties (albedo_0..2) was written by PTIR or the add-on, in
//      Blender's frame: +z. Any other PLY (INRIA layout, SuperSplat compressed)
//      is a trainer's output in its capture's frame: -y, COLMAP's convention
//      (its world is the first photo's camera frame, whose y points down; the
//      PLY viewers turn such files over for the same reason).
#pragma once

#include <string>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussians.h"

namespace ptir {

struct UpCue {
  bool available = false;  // the data had what the cue needs
  bool clear = false;      // ... and it passed its thresholds
  Vec3 up;                 // its answer (unit) when available
  float axis_clarity = 0, sign_clarity = 0;  // the SH cue's measures; cameras: |mean up| in axis_clarity
  std::string note;        // why it is not available or not clear
};

struct UpAxis {
  Vec3 up{0, 0, 1};     // unit
  std::string source;   // "flag", "cameras", "sh", "ptir file", "trainer convention"
  UpCue cameras, sh;    // the cues as measured (for OUT/views.json)
};

// "x", "-y", "z", ... or "X,Y,Z" (any non-zero vector; normalised). Throws
// ptir::Error naming the text for anything else.
Vec3 parse_up_axis(const std::string& text);

// The cues on their own (tests and the record).
UpCue up_from_cameras(const std::vector<Camera>& cameras);
UpCue up_from_sh(const GaussianField& field);

// The rule above. `flag` is the --up text ("" when not given); `cameras` the
// --cameras poses (empty when not given).
UpAxis decide_up_axis(const GaussianField& field, const std::string& flag, const std::vector<Camera>& cameras);

// The decision as a JSON object: {"up": [x, y, z], "source": ..., "cues": {...}}.
std::string up_axis_json(const UpAxis& up);

// A views document (a JSON object) with the decision added as its "up_axis".
std::string with_up_axis(const std::string& views_json, const UpAxis& up);

}  // namespace ptir
