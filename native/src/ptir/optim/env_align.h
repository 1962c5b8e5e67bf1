// A known environment map lined up with the photos before the inversion (issue 52):
// its rotation about the up axis (+z, the yaw), and where the photos can tell, its
// exposure and white balance (one scale per channel).
//
// A user's HDRI (a 360-degree camera, a chrome ball, a downloaded sky) is never in the
// scene's orientation or exposure. `--env-init MAP` takes it as given unless aligned:
//
//   yaw     every candidate rotation_z (radians, the Mapping node's Z rotation of
//           lights/environment.h: the yaw a Blender World would need) is scored by a
//           forward render of a few training views, reduced to at most max_pixels
//           pixels, at low spp and bounces, with the materials at their start. The
//           score is scale-invariant per channel: the photos' share the render does
//           not explain after the best scale of each channel,
//             score = sum_c (sum P^2 - (sum P R)^2 / sum R^2) / sum_c sum P^2
//           over the object's pixels (photo alpha and render coverage both >= 0.99),
//           plus the same over the background where the photos see the environment
//           (opaque photos, the render's coverage <= 0.01). A coarse search every
//           coarse_step degrees, then every degree within one coarse step of the best.
//           Every candidate uses the same random numbers, so their differences are
//           not Monte Carlo noise. A map that already fits keeps 0: the best wins
//           only if its score is lower than 0's by more than keep_margin (relative).
//   scale   the photos' level against the render's, per channel (sum P R / sum R^2):
//           - over the background where the photos see it: that IS the map's
//             exposure and white balance (the background is the map itself);
//           - over the object only (masked photos): the level is the albedo's times
//             the light's, and no image tells one from the other (the evaluation
//             compares albedo after a per-channel scale for this reason). "full" then
//             assumes the object's mean albedo: one scale that makes its luminance
//             reference_albedo (one exposure; the map's colour is kept:
//             a tint measured 0-0.3 dB, a level 2-5 dB). "search" starts there and the
//             optimiser picks the exposure by short inversions at candidate levels
//             (Optimizer::search_known_level: the highlights, the bounce light and the
//             albedo's bound, read with a roughness the inversion has fitted).
//
// Modes: off (the map as given), yaw (rotation only: the map's level kept), auto
// (rotation, the scale where the background shows it, and on masked photos of a map held
// fixed the search's exposure), full (rotation and scale; on masked photos the exposure
// from the mean-albedo assumption), search (auto, searching on masked photos whether the
// map is fixed or learnt). The result is baked into the texels (the rotation by linear interpolation
// along each row; yaw 0 leaves them bit for bit), so OUT/env.exr stays in the
// scene's orientation. docs/known_light.md has the measurements.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/math/vec.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/render_settings.h"
#include "ptir/scene/scene.h"
#include "ptir/transport/path_tracer.h"

namespace ptir {

enum class EnvAlignMode { Off, Yaw, Auto, Full, Search };
const char* env_align_mode_name(EnvAlignMode m);
EnvAlignMode parse_env_align_mode(const std::string& name, const std::string& what);

// --env-refine: the known map learnt at this share of the environment's rate (both levels).
constexpr float kEnvRefineRate = 0.1f;

struct EnvAlignSettings {
  EnvAlignMode mode = EnvAlignMode::Off;
  int views = 6;                // training views scored, spread over the set
  int max_pixels = 64 * 64;     // each reduced (view_pyramid.h) to at most this many pixels
  int spp = 4;
  int bounces = 1;              // at most the inversion's
  float coarse_step_deg = 10.0f;
  float keep_margin = 0.01f;    // 0 degrees stays unless beaten by this relative share
  float reference_albedo = 0.5f;  // "full" on masked photos: the object's mean albedo (luminance) assumed
  // The map is held fixed in the inversion (--fix-env): "auto" then searches its level on
  // masked photos as "search" does (a learnt map's level moves with the inversion itself).
  bool map_fixed = false;
  // "search" (and "auto" on a fixed map) on masked photos: short inversions of this share of the run's iterations (at
  // least level_min_iterations) at levels level_step apart (log2) around the mean-albedo one.
  float level_iterations_share = 0.5f;
  int level_min_iterations = 30;
  float level_step = 0.5f;
  float level_max_log2 = 2.0f;  // the search goes at most this far (log2) from its start
};

struct EnvAlignResult {
  EnvAlignMode mode = EnvAlignMode::Off;
  double yaw_deg = 0;            // the rotation_z baked into the texels, in [0, 360)
  Vec3 scale{1.0f};              // per channel, applied to the texels
  std::string scale_from = "none";  // "background", "mean albedo", "short inversions" or "none" (the map's own level)
  // Mode search on masked photos (the optimiser's search_known_level): each candidate's
  // factor on the mean-albedo start and its short inversion's loss, the factor chosen
  // (already in `scale`), the iterations of each and the seconds they took in all.
  std::vector<std::pair<double, double>> level_candidates;
  double level_factor = 1;
  int level_iterations = 0;
  double level_seconds = 0;
  Vec3 photo_level{0.0f};        // the photos' level against the render's, per channel (object)
  Vec3 background_level{0.0f};   // ... over the background (0: not seen)
  double score = 0, score_unaligned = 0;  // at the solved yaw, and at 0 degrees
  std::vector<std::pair<double, double>> candidates;  // (yaw in degrees, score), in the order scored
  int views = 0, pixels = 0;     // views scored, and their object pixels in all
  double seconds = 0;
  // The record OUT/settings.json keeps under "env_align" (a JSON object).
  std::string json() const;
  // One line for the log.
  std::string summary() const;
};

// The lat-long texels (row-major RGB, width x height) with rotation_z = yaw_rad baked
// in: looked up without rotation they give what the input gives with it.
std::vector<float> rotate_latlong_yaw(const std::vector<float>& texels, int width, int height, double yaw_rad);

// The vertex of the least-squares parabola through (t, score) points, if it opens
// upward and lies within [-limit, limit]; else NaN.
double parabola_vertex(const std::vector<std::pair<double, double>>& pts, double limit);

// Aligns scene.environment (a lat-long Environment holding the map as given) to the
// dataset's photos: renders with `tracer` (built on `scene`, its materials at their
// start), leaves the aligned texels in scene.environment (sampling rebuilt) and
// returns what it found. `base` is the inversion's integrator (filter, interaction).
EnvAlignResult align_environment(Scene& scene, const PathTracer& tracer, const Dataset& data,
                                 const IntegratorSettings& base, const EnvAlignSettings& s);

}  // namespace ptir
