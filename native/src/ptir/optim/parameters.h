// The optimised parameters of the inversion (docs/method.md §6), held raw (unconstrained)
// for Adam, and their activations into the scene the renderer reads:
//
//   Gaussian albedo     a = sigmoid(x)                    (3 per Gaussian)
//   Gaussian roughness  r = 0.09 + 0.9 sigmoid(x)         (PTIR's range [0.09, 0.99])
//   Gaussian metallic   m = sigmoid(x)                    (optional; else fixed, default 0)
//   environment         the model's own raw view (EnvironmentLight::set_raw):
//     lat-long texel    L = exp(x)                        (3 per texel, strength 1)
//     SG amplitudes     x itself (SgEnvironment activates c = exp(softplus(x)/gamma) - 1)
//     constant colour   L = exp(x)                        (3)
//   mesh materials      base colour sigmoid, roughness as above, metallic sigmoid (optional)
//
// Geometry, opacity and normals are not parameters (fixed during inversion).
// The renderer's adjoints (SceneGradients) are with respect to the ACTIVATED
// values; raw_gradients() chains them through the activations.
#pragma once

#include <string>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/optim/env_pyramid.h"
#include "ptir/scene/scene.h"
#include "ptir/transport/gradients.h"

namespace ptir {

// The learnable environment model: lat-long map, spherical Gaussians, or one colour;
// or None: no environment at all (black), the scene file's lights and emissive meshes
// are the only light (known lamps and walls, docs/inversion.md "Known lamps").
enum class EnvMode { LatLong, SG, Constant, None };
// "latlong", "sg", "color" (the scene-JSON type names), "none"; parse throws Error
// "<what> must be 'latlong', 'sg', 'color' or 'none', got 'x'".
const char* env_mode_name(EnvMode m);
EnvMode parse_env_mode(const std::string& name, const std::string& what = "env");

// Activations (exposed for tests).
constexpr float kRoughnessMin = 0.09f;
constexpr float kRoughnessRange = 0.9f;
// sigmoid/logit: math/vec.h.
float logit_clamped(float p);  // logit of p clamped into [1e-6, 1 - 1e-6]
inline float roughness_from_raw(float x) { return kRoughnessMin + kRoughnessRange * sigmoid(x); }
float roughness_to_raw(float r);  // clamps r into the activation's open range

struct ParameterSettings {
  float init_albedo = 0.3f;     // docs/method.md §6
  // Start the Gaussians' albedo, roughness (and optimised metallic) from the field's
  // own values (a PLY that carries albedo_*, roughness, metallic: a previous result
  // to refine, or the true materials to test where the optimum lies) instead of
  // the constants above; values are clamped into the activations' open ranges.
  bool init_from_field = false;
  float init_roughness = 0.6f;
  float init_metallic = 0.0f;   // the fixed value when metallic is not optimised
  // Start of an optimised metallic: away from 0, where sigmoid is flat (logit(0) = -inf).
  float init_metallic_optimised = 0.05f;
  bool optimize_metallic = false;
  EnvMode env = EnvMode::LatLong;
  int env_width = 128, env_height = 64;  // the benchmark setting
  float env_init = 0.5f;                 // lat-long texels (or the constant) start at this radiance (PTIR)
  // Known lighting: start the lat-long environment from this map (its size wins
  // over env_width/height) instead of the constant env_init.
  std::string env_init_path;
  // The environment seen directly (a real capture's background, optim/capture_analysis.h):
  // the env_init_path map's texels whose 4th channel is over 0.5 are known and held at their
  // value; the others are learnt (the coarse level learns from those alone).
  bool env_init_seen_fixed = false;
  // ... or their fine level held (the photos' detail) while the coarse level's smooth change
  // still learns from them; the unseen texels learn both levels (a real capture's background
  // start, pipeline/capture_stage.h: docs/captures.md).
  bool env_init_seen_coarse = false;
  bool optimize_env = true;              // false: the environment is held fixed
  int sg_lobes = 24;
  // Coarse-to-fine lat-long environment (env_pyramid.h): the width of the coarse
  // level (its height is half, at least 1); 0 = texels only; -1 (default) = 1/8 of
  // the map's width for maps at least 32 texels wide (16x8 for 128x64), else none.
  // Measured (docs/inversion.md): +1.2 to +1.9 dB albedo, environment PSNR
  // 18.5 -> 22.4 dB, at the same cost.
  int env_coarse_width = -1;
  // With a coarse level: the fine texels learn at lr_env x this (the coarse level at
  // lr_env). Below 1 the fine texels' random walk on converged pixels' noise
  // (see lr_env) shrinks while the coarse level keeps the light's broad shape moving.
  // Half, with lr_balance 0.1 (measured together, docs/inversion.md, 400 x 8):
  // the sample +0.7 / +0.4 dB albedo on two seeds (linear +1.3 / +1.7), the
  // textured set unchanged (+0.01 / +0.05); alone, 25 % lost 0.15 dB textured.
  float env_fine_lr_scale = 0.5f;
  bool optimize_meshes = false;          // mesh materials of a --scene, one set per mesh
  bool learn_exposure = false;           // one log-exposure per training view (optim/exposure.h)
  float lr_exposure = 0.03f;
  // The light-albedo balance's Adam rate (light_balance.h): 0.1 (0.03 before; with
  // env_fine_lr_scale, above) -- the level is one number per channel whose evidence
  // is small against the per-Gaussian steps' noise; a faster balance lands nearer it.
  float lr_balance = 0.1f;
  // Adam learning rates (PTIR code), but the environment's at half of PTIR's 0.035: with the
  // decorrelated adjoint a converged pixel's L1 sign is noise independent of the texels its
  // replay reaches, and Adam's per-texel normalisation turns that noise into a random walk of
  // about lr per step (speckle, colour noise in the light). Measured at 400 iterations x 8 spp
  // (docs/inversion.md): albedo +0.8 dB on the textured set, +1.3 dB on the sample; a quarter
  // of PTIR's rate loses on the textured set.
  float lr_albedo = 0.035f, lr_roughness = 0.025f, lr_metallic = 0.035f, lr_env = 0.0175f, lr_mesh = 0.035f;
};

// The numbers are stored in checkpoints. 4 was the SG environment's before every
// environment became one group; checkpoints read it as Environment.
enum class ParamKind {
  GaussianAlbedo = 0,
  GaussianRoughness = 1,
  GaussianMetallic = 2,
  Environment = 3,
  MeshColour = 5,
  MeshRoughness = 6,
  MeshMetallic = 7,
  Exposure = 8,  // per-view log exposure (optim/exposure.h), added by the optimiser
  EnvironmentCoarse = 9,  // the coarse level of a lat-long environment (env_pyramid.h)
  // The geometry stage (optim/geometry_fit.h): raw per-Gaussian geometry, radiance
  // and normals, and its densification statistics and log rows (no Adam).
  GaussianPosition = 10,
  GaussianLogScale = 11,
  GaussianRotation = 12,
  GaussianOpacity = 13,
  GaussianShDc = 14,
  GaussianShRest = 15,
  GaussianNormal = 16,
  FitStatistics = 17,
  FitLogRows = 18,
  LightBalance = 19,  // per-channel log light-albedo balance (optim/light_balance.h), added by the optimiser
  LastKind = LightBalance
};
const char* param_kind_name(ParamKind k);

struct ParameterGroup {
  ParamKind kind;
  float lr = 0.0f;
  std::vector<float> raw;
};

struct Parameters {
  std::vector<ParameterGroup> groups;
  // Per raw value of the environment: the known log radiance (NaN: learnt); empty: none
  // (ParameterSettings::env_init_seen_fixed).
  std::vector<float> env_known;
  bool env_known_coarse = false;  // ParameterSettings::env_init_seen_coarse: env_known holds the fine level only
  const ParameterGroup* find(ParamKind k) const;
  ParameterGroup* find(ParamKind k);
  size_t count() const;  // scalars in all groups
};

// Replaces the scene's environment with the learnable one of `s` (lat-long of
// env_width x env_height at env_init, sg_lobes SGs at PTIR's initialisation, or
// a constant env_init), or removes it (EnvMode::None).
void install_environment(Scene& scene, const ParameterSettings& s);

// Raw parameters at the initial values of `s`, sized for `scene` (whose
// environment install_environment has set up).
Parameters make_parameters(const Scene& scene, const ParameterSettings& s);

// Writes the activated values into the scene (Gaussian materials, environment
// texels or SG amplitudes with their sampling rebuilt, mesh materials). Fixed
// metallic is set to s.init_metallic.
void apply_parameters(const Parameters& p, const ParameterSettings& s, Scene& scene);

// The upsampler of a coarse environment group (a cw x max(1, cw/2) RGB grid)
// onto the scene's lat-long environment; throws Error for other models or sizes.
LatlongUpsampler coarse_upsampler(const ParameterGroup& coarse, const Scene& scene);

// dLoss/d(raw) for every group, from the adjoints w.r.t. activated values; same
// shapes as the groups' raw vectors. Reads the current activated values from raw;
// the environment group is chained by the scene's environment model.
std::vector<std::vector<float>> raw_gradients(const Parameters& p, const SceneGradients& g, const Scene& scene);

}  // namespace ptir
