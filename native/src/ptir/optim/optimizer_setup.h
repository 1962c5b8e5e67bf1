// The set-up shared by `ptir optimize` (pipeline/optimize_pipeline.h) and the Python
// module's ptir.Optimizer / ptir.optimize (python/bind_optimize.cpp): the
// options both take, checked and turned into OptimizerSettings, and the scene
// the optimiser starts from.
//
// Messages name the options the way the caller spells them: OptionNames maps a
// snake_case name ("env_init") to "--env-init" for the CLI and leaves it as is
// for Python.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "ptir/optim/optimizer.h"
#include "ptir/scene/scene.h"

namespace ptir {

using OptionNames = std::function<std::string(const std::string& snake_case)>;
std::string cli_option_name(const std::string& snake_case);     // "env_init" -> "--env-init"
std::string python_option_name(const std::string& snake_case);  // unchanged

struct OptimizeOptions {
  int iters = 800;
  int spp = 32;
  int bounces = 2;
  // Where a ray leaving a vertex takes its light when it meets the splats: "path"
  // (another vertex, shaded with the current estimate) or "field" (the splats'
  // captured radiance; IntegratorSettings::indirect_from_field). "auto" is "path"
  // here; `ptir optimize` makes it "field" when its geometry stage fitted the
  // splats' SH to the photos (then they hold what the photos saw).
  std::string indirect = "auto";
  uint64_t seed = 0;
  int views_per_iter = 1;
  int crop = 0;
  int coarse_pixels = OptimizerSettings{}.coarse_pixels;    // resolution pyramid (view_pyramid.h; 0: off)
  float fine_fraction = OptimizerSettings{}.fine_fraction;  // its last share at full resolution
  int coarse_spp = OptimizerSettings{}.coarse_spp;          // its coarse phase's spp (0: spp)
  std::string loss_space = "srgb-blur-first";  // srgb-blur-first, srgb or linear (optimizer.h)
  float lambda_tv = OptimizerSettings{}.lambda_tv;
  float tv_chroma = OptimizerSettings{}.tv_chroma;  // the albedo TV's chromaticity guide (0: intensity)
  float lr_final = OptimizerSettings{}.lr_final;
  float lr_decay_start = OptimizerSettings{}.lr_decay_start;
  // The albedos' start: PTIR's 0.3. A 0.5 start measured +1.5 / +2.0 dB albedo and
  // +0.6 / +0.7 dB relight on two textured sets (whose albedos average ~0.5) but
  // -0.3 / -1.1 dB albedo on the four-colour sample at 100 px and 48 px: the
  // recovered level stays near the start on every set, so a start is a guess about
  // the data, not a fix (docs/inversion.md).
  float init_albedo = ParameterSettings{}.init_albedo;
  bool init_from_ply = ParameterSettings{}.init_from_field;
  bool light_balance = OptimizerSettings{}.light_balance;
  bool neutral_light = OptimizerSettings{}.neutral_light;
  float lr_balance = ParameterSettings{}.lr_balance;
  float balance_start = OptimizerSettings{}.balance_start;
  float lambda_albedo_grey = OptimizerSettings{}.lambda_albedo_grey;
  float lr_env = ParameterSettings{}.lr_env;  // the environment's Adam rate (both levels)
  float lr_albedo = ParameterSettings{}.lr_albedo;        // the Gaussians' albedo logits' Adam rate
  float lr_roughness = ParameterSettings{}.lr_roughness;  // the Gaussians' roughness logits' Adam rate
  float lr_metallic = ParameterSettings{}.lr_metallic;    // the Gaussians' metallic logits' Adam rate (when optimised)
  float env_fine_rate = ParameterSettings{}.env_fine_lr_scale;  // the fine texels' share of it
  int env_coarse = ParameterSettings{}.env_coarse_width;
  // -1: automatic, resolved by prepare_optimizer_scene (OptimizerSettings' 0.5, or 0 where the scene
  // file's own light and a learnt environment meet: see kSceneLitEnvStart).
  float albedo_warmup = -1.0f;
  float tv_warmup = OptimizerSettings{}.tv_warmup;
  bool decorrelate_adjoint = OptimizerSettings{}.decorrelate_adjoint;
  // D-SSIM's share of the image loss: 0 by default (PTIR's 0.2 is --lambda-ssim 0.2).
  // The SSIM of a half-sample render counts its noise as signal variance and asks
  // for more contrast than the target's (losses.h); measured with
  // the bounded self-skip on three sets (400 iterations; docs/objective.md):
  // albedo +0.21 / +0.05 / +0.97 dB, relight +0.10 / 0.00 / +0.25, NVS +1.1 / +1.1 /
  // +0.4, roughness MSE +0.0006 / +0.0004 / -0.0009.
  float lambda_ssim = 0.0f;
  bool loss_blur = ImageLossSettings{}.binomial_filter;     // 3x3 binomial blur of the prediction in the loss
  // ... and of the target: on by default, so the loss's optimum is the unblurred
  // match (blurring the render alone asks for a render sharper than the photo).
  // With the bounded self-skip: albedo +0.3 / +0.36 dB, relight +0.1 on two textured
  // sets, +0.43 dB on the four-colour sample at 48 px (docs/objective.md).
  bool loss_blur_target = true;
  std::string env = "latlong";  // EnvMode name: latlong, sg, color, none
  int env_width = 128, env_height = 64;
  std::string env_init;          // "" = constant start
  bool fix_env = false;
  bool fix_env_seen = false;     // hold env_init's seen texels (its alpha) fixed
  // What the env_init map's seen texels learn: learn (both levels, as every texel), coarse (their
  // fine level held at the photos' detail, the coarse level's smooth change learnt; unseen texels
  // learn both), fixed (= fix_env_seen); auto: learn here, coarse where the pipeline starts the
  // map from a real capture's seen background.
  std::string env_seen = "auto";
  // The env_init map lined up with the photos first (env_align.h): auto, off, yaw or full.
  // Not for the seen texels (--fix-env-seen: a map made from the photos is theirs already).
  std::string env_align = "auto";
  // Learn the (aligned) env_init map gently: at env_refine_rate times lr_env (the issue-52
  // middle ground between --fix-env and a map learnt like an unknown one).
  bool env_refine = false;
  // A real capture's object: every pixel of a patch supervised, its coverage mask picking where
  // the patches go (OptimizerSettings::background_loss): on, off, or auto (off here; the
  // pipeline resolves it from the capture's subject).
  std::string background_loss = "auto";
  float object_patch_share = OptimizerSettings{}.object_patch_share;
  bool optimize_metallic = false;
  bool optimize_meshes = false;
  bool learn_exposure = false;  // one exposure scale per training view (exposure.h)
  int k = AccelSettings{}.k;     // k-buffer size of the tracer
  // What the primal keeps for the replay (OptimizerSettings::sample_cache_bytes), MB.
  int sample_cache_mb = int(OptimizerSettings{}.sample_cache_bytes >> 20);
};

// The checked settings; throws Error naming the offending option.
OptimizerSettings optimizer_settings(const OptimizeOptions& o, const OptionNames& names);

// A learnt environment's start where the scene file brings light of its own (lamps or emissive
// meshes), with the albedos learning from the first iteration (an automatic albedo_warmup is 0).
// Measured on a Cycles room lit by two known area lights in a black world (docs/known_lamps.md,
// 300 x 8): from the default start (0.5, warm-up 0.5) the environment kept the lamps' light and
// the albedo came out 28.5 dB, 40-60 % too dark; started at 0.02, 31.9 dB (13-28 % dark); and
// with no warm-up 33.8 dB, 3-7 % (the lamps alone, --env none: 34.7 dB, 1 %).
constexpr float kSceneLitEnvStart = 0.02f;

// The scene the optimiser starts from: the scene file's meshes and lights (none
// when scene_path is ""), whose interaction settings replace those of `s` (its
// spp/bounces do not), with `field` as its Gaussians. A scene file with Gaussians
// is refused (they come from one PLY); its environment is replaced by the
// learnable one later (or removed: EnvMode::None, which needs a lamp or an
// emissive mesh in the file), and `note` (optional) is told so. optimize_meshes
// needs a scene file. Resolves an automatic albedo warm-up, and starts a learnt
// environment at kSceneLitEnvStart where the file has lamps or emissive meshes.
Scene prepare_optimizer_scene(const std::string& scene_path, std::shared_ptr<GaussianField> field, OptimizerSettings& s,
                              const OptionNames& names, const std::function<void(const std::string&)>& note = {});

}  // namespace ptir
