// The inversion loop (docs/method.md §6): Adam on activated-parameterised materials and
// environment, gradients by path replay backpropagation.
//
// One iteration:
//   1. views: views_per_iteration slots; slot j = it * k + v takes position j % N
//      of a permutation of the N views drawn for epoch j / N (every view once per
//      epoch). Optionally a random crop_size^2 window, centred at a uniformly drawn
//      pixel of the view's mask bounding box (clamped into the image).
//   2. render_path at spp, with the path seed hash(seed, it, v).
//   3. image loss (1 - 0.2) L1 + 0.2 D-SSIM through the 3x3 binomial filter
//      (losses.h) between the render and the target, both in sRGB space by
//      default (see below), masked; its gradient through the sRGB curve is pushed
//      through render_path_backward (same seed: the replay sees the same paths).
//   4. regularisers on the primary-hit albedo/roughness maps (render_aov, pixel
//      centres, same seed): edge-aware TV (lambda_tv, guide = target in loss
//      space) and, when the dataset has prior maps, L2 to them with a weight
//      decaying linearly from prior_start to prior_end over prior_iterations;
//      their gradients through render_aov_backward.
//   5. chain rule into the raw parameters, one Adam step per group, write the
//      activated values back into the scene (environment sampling rebuilt).
//
// Loss space: sRGB by default, as PTIR (its ground truth are sRGB photos, and
// D-SSIM's constants assume display values in [0, 1]); it weights dark regions
// more than linear L1 does. The curve used is the sRGB encoding extended above
// 1 without clamping (1.055 c^(1/2.4) - 0.055), so over-bright predictions keep
// a gradient; its derivative multiplies the loss gradient. --loss-space linear
// compares linear radiance instead. The render's 3x3 blur comes before the curve
// (srgb_after_blur, "srgb-blur-first", the default): the curve is concave, so the
// sRGB of a noisy pixel is on average darker than the sRGB of its mean, and with
// few samples per decorrelated half the loss read every render as too dark (2 spp
// from the truth: the albedo 25 % too bright, NVS -5 dB; docs/objective.md);
// blurred first, the variance the curve sees is about 1/7.
//
// Mask: the render shows the environment where camera rays escape; targets with
// alpha are objects on a transparent background. The loss uses the pixels where
// the target's alpha AND the render's coverage (fraction of samples that found a
// surface; fixed: geometry is not optimised) are both >= mask_threshold (0.99),
// so silhouette pixels -- a blend of object and background whose background
// half differs between the two -- neither bias the materials nor the
// environment. Outside the mask the prediction is replaced by the target before
// the blur and SSIM, so no gradient leaks through their windows to unmasked
// pixels. Targets without alpha use every pixel (the environment seen
// directly then supervises the environment too). The regularisers use the pixels
// whose target alpha >= mask_threshold and whose primary ray found a valid
// interaction (AOV coverage > tau_g).
//
// Determinism: every random choice is keyed on (seed, iteration), parameters
// change only at the end of an iteration, and the renders/backward passes are
// deterministic for a fixed thread count; so a run resumed from a checkpoint
// (checkpoint.h) is bit-identical to an uninterrupted one on the same thread count.
#pragma once

#include <array>
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/communicator.h"
#include "ptir/scene/dataset.h"
#include "ptir/optim/adam.h"
#include "ptir/optim/checkpoint.h"
#include "ptir/optim/env_align.h"
#include "ptir/optim/exposure.h"
#include "ptir/optim/losses.h"
#include "ptir/optim/parameters.h"
#include "ptir/optim/run_loop.h"
#include "ptir/render/aov.h"
#include "ptir/scene/scene.h"
#include "ptir/transport/gradients.h"
#include "ptir/transport/path_tracer.h"

namespace ptir {

// The integrator settings of the inversion (see OptimizerSettings::integrator).
inline IntegratorSettings inversion_integrator() {
  IntegratorSettings s;
  s.min_specular_probability = 0.5f;
  // Every light at every vertex: each light's gradients (the environment's above all)
  // from every path vertex, rather than from the 1 / N of them that pick it.
  s.light_selection = LightSelection::All;
  s.russian_roulette = false;
  return s;
}

struct OptimizerSettings {
  int iterations = 800;           // docs/method.md §6
  // spp 32, 2 bounces (its seed is replaced per iteration); specular samples at least
  // half of the Principled BSDF's (measured on tests/blender's recovery scene, 200
  // iterations: glossy sphere roughness 0.63 with Cycles' lobe weights, 0.46 with this,
  // truth 0.25).
  IntegratorSettings integrator = inversion_integrator();
  uint64_t seed = 0;
  int views_per_iteration = 1;
  int crop_size = 0;              // 0: whole images; else square crops of this side
  // The resolution pyramid (view_pyramid.h): for the first (1 - fine_fraction) x
  // iterations, views with more than coarse_pixels pixels are rendered reduced by a
  // power of two to at most that many (with the automatic batch: whole reduced views
  // where they are small enough, default_patch_batch); the rest at full resolution.
  // 0: off.
  int coarse_pixels = 0;
  float fine_fraction = 0.25f;
  // The coarse phase's samples per pixel (0: integrator.spp): a budget's plan
  // (budget_plan.h) steps the spp one phase at a time, the coarse one first.
  int coarse_spp = 0;
  ImageLossSettings loss;         // lambda_s 0.2, binomial filter on
  bool srgb_loss = true;          // compare in sRGB space (false: linear)
  // With srgb_loss and the loss's blur: blur the linear render, then take the curve ("srgb-blur-first").
  bool srgb_after_blur = true;
  float mask_threshold = 0.99f;
  // A real capture's object (pipeline/capture_stage.h): its coverage masks pick where the
  // patches go, but every pixel of a patch is supervised, so the background seen around the
  // object supervises the environment (the way targets without alpha do). object_patch_share
  // of the patches are centred on the mask's box, the rest anywhere in the view. The
  // regularisers keep to the mask.
  bool background_loss = false;
  float object_patch_share = 0.75f;
  // The edge-aware TV of the albedo and roughness maps (PTIR's 0.095), and the albedo's
  // guide: 0 the loss-space target (intensity edges); > 0 the linear target's chromaticity at
  // this sharpness (losses.h: chroma_guide), so a shadow edge over one colour is smoothed and a
  // colour edge is not (roughness keeps the target). --lambda-tv 3 --tv-chroma 30 measured on
  // the family (docs/blind_light.md): held-out albedo +0.24 dB at 200 x 4, but started from the
  // true materials the 48-px fixed-point set drifts from 35.24 to 30.79 dB and the known-lamps
  // room loses 0.4 dB, and the default budget was not measured: an option, not the default.
  float lambda_tv = 0.095f;
  float tv_chroma = 0.0f;
  float prior_start = 0.5f, prior_end = 0.005f;
  int prior_iterations = 400;
  ParameterSettings params;
  AdamSettings adam;
  // Learning-rate schedule: every group's rate is constant up to lr_decay_start x
  // iterations, then decays exponentially to lr_final x its rate at the last
  // iteration (1 = PTIR's constant rate). See lr_factor(). Measured
  // (docs/inversion.md): +1.0 dB albedo and roughness MSE 0.0057 -> 0.0050 on the textured set,
  // +0.4 dB on the sample; the last steps no longer leave per-Gaussian noise of
  // the full rate.
  float lr_final = 0.1f;
  float lr_decay_start = 0.5f;
  // Light first: the albedo groups' rates (Gaussians' and meshes' base colours) ramp
  // linearly from 0 to full over the first albedo_warmup x iterations, so the
  // shading goes to the light before per-Gaussian albedos can absorb it (0: off).
  // Roughness keeps its full rate: a highlight's width must go to roughness, not
  // into a sharper environment. Measured
  // (docs/inversion.md) on the textured set, albedo only at 0.5: +2.5 dB albedo,
  // roughness MSE 0.0050 -> 0.0032; on the sample's uniform parts -0.6 dB; a uniform
  // glossy sphere keeps a rougher value (tests/blender/test_optimize_recovery.py).
  float albedo_warmup = 0.5f;
  // The TV weight starts at tv_warmup x lambda_tv and falls linearly to lambda_tv at
  // half the iterations (1: constant).
  float tv_warmup = 1.0f;
  // Learn the light-albedo balance (light_balance.h): one log scale per channel
  // moving all albedos against the lat-long environment, driven by the
  // interreflections and highlights that the per-parameter steps cannot resolve.
  // Measured (docs/inversion.md): see balance_start.
  bool light_balance = true;
  // After every step, the environment's colour goes into the albedos so that the
  // light stays neutral (light_balance.h: neutral_light_delta). On for `optimize`
  // without --dataset, where nothing else splits the baked colour.
  bool neutral_light = false;
  // The balance learns from balance_start x iterations on: before, the image's
  // overall misfit drives it (it brightens the highlights through the light,
  // which the albedo cannot), not the evidence of the level -- measured: from
  // the start it first fell to 0.59 in 30 iterations, then climbed back. From
  // half the run (after the albedo warm-up): +0.1 / +0.1 dB albedo (sRGB /
  // linear) on the textured set, +0.3 / +0.7 on the sample; from a quarter:
  // +0.5 / +0.6 and -0.6 / +0.8 (the sample's per-channel levels go astray),
  // and a 60-iteration add-on run ended with a darker albedo level.
  float balance_start = 0.5f;
  // Weight of the grey-world prior on the albedos' colour along the balance
  // (light_balance.h, albedo_chroma_prior): pulls the learnt albedos' mean colour
  // toward grey in the one direction the direct diffuse images cannot see (the
  // light takes the opposite colour), so the data's evidence there (highlights,
  // interreflections) can override it. 0: off. Measured on the family
  // (docs/family.md): 0.001 narrows the channels' spread on the coloured-light
  // test (8-12 % -> 3.5-5 %) and on the tuning half at an unchanged albedo PSNR,
  // and costs the demo 0.17 dB; 0.01 makes the spread < 1 % there but costs the
  // demo's orange-red object 1.0 dB (grey world is wrong for it).
  float lambda_albedo_grey = 0.001f;
  // Decorrelated adjoint: with gradients, the spp are rendered as two independent
  // halves and each half's replay is weighted by dL/dimage of the other half. With
  // one set of samples for both, the noise of a pixel's estimate and of its
  // derivative are correlated, so the step follows the gradient of the *expected
  // noisy loss*, E[L(I_spp)] = L(E I) + a variance term: it also drives the scene
  // toward lower Monte Carlo variance -- a flatter environment (the recovered light
  // lost its highlights and brightened below, the albedo took the shading), more
  // so the longer the run and the fewer the samples. Independent halves remove
  // that term (for an L2 loss exactly; Mitsuba 3 decorrelates its adjoint render
  // for the same reason) at no extra cost: the same samples, split.
  bool decorrelate_adjoint = true;
  bool orient_normals = true;     // shortest-axis normals faced toward the training cameras
  // The primal pass keeps every sample's radiance and shadow-ray outcomes (20 bytes
  // per pixel and sample) so the replay need not recompute them, while that fits this budget; beyond it
  // the replay recomputes each sample (one more primal pass, no memory). What the
  // budget leaves keeps the samples' walks (~100 bytes a sample; walk_store.h), so
  // that the replay need not walk them again; the samples beyond it walk.
  size_t sample_cache_bytes = size_t(256) << 20;
  AccelSettings accel;
  // The --env-init map lined up with the photos before the first iteration (env_align.h).
  EnvAlignSettings env_align;
};

class Optimizer {
 public:
  // Takes the scene (Gaussians, optional meshes and lights; its environment is
  // replaced by the learnable one), builds the tracer, orients normals, and sets
  // the initial parameters.
  Optimizer(Scene scene, std::shared_ptr<const Dataset> dataset, const OptimizerSettings& settings);
  ~Optimizer();

  int iteration() const { return iteration_; }  // completed iterations
  const OptimizerSettings& settings() const { return settings_; }
  // The target iteration count may change (a resumed run can go further).
  void set_iterations(int n) { settings_.iterations = n; }
  // The samples per pixel of the iterations to come (a time budget plans them; budget_plan.h).
  void set_spp(int spp) { settings_.integrator.spp = spp; }
  void set_coarse_spp(int spp) { settings_.coarse_spp = spp; }
  // The full-resolution batch's patch count (the budget's plan, budget_plan.h); the pyramid's
  // coarse levels keep their automatic batch.
  void set_views_per_iteration(int views) { settings_.views_per_iteration = views; }
  // The resolution pyramid's full-resolution share (a budget's plan, before the first iteration).
  void set_fine_fraction(float f) { settings_.fine_fraction = f; }
  // Whether the patches per iteration were left automatic (--views-per-iter not given).
  bool auto_views() const { return auto_views_; }
  // Data-parallel runs (optim/data_parallel.h): every rank's optimiser shares each
  // iteration's views through `comm` (which must outlive it); default: one process.
  void set_communicator(const Communicator& comm) { comm_ = &comm; }
  const Communicator& communicator() const { return *comm_; }

  // One iteration. With `cancel` set the renders stop early and Cancelled is
  // thrown; the state is then that of the last completed iteration.
  IterationLog step(const std::atomic<bool>* cancel = nullptr);

  // The objective of (0-based) iteration `it` at the current parameters -- the
  // same views, crops and random numbers step() would use -- without changing
  // anything but gradients(); with `with_gradients` its adjoints w.r.t. the
  // activated parameters land in gradients() (raw_gradients() chains them).
  IterationLog evaluate(int it, bool with_gradients, const std::atomic<bool>* cancel = nullptr);
  const SceneGradients& gradients() const { return grads_; }
  // Replaces the raw parameters (same groups and sizes) and applies them.
  void set_parameters(const Parameters& p);

  // Prior-map weight at (0-based) iteration it.
  double prior_weight(int it) const;
  // The learning-rate multiplier at (0-based) iteration it (the schedule above), and
  // the extra one of the albedo groups (albedo_warmup).
  double lr_factor(int it) const;
  double albedo_lr_factor(int it) const;
  // A linear ramp from 0 to 1 over the first `fraction` x iterations (0: always 1).
  double warmup_factor(float fraction, int it) const;
  // The TV weight at (0-based) iteration it.
  double tv_weight(int it) const;

  Fingerprint fingerprint() const;
  Checkpoint checkpoint() const;
  void restore(const Checkpoint& c, const std::string& path_for_messages = "checkpoint");
  void save_checkpoint(const std::string& path) const { write_checkpoint(path, checkpoint()); }
  void load_checkpoint(const std::string& path) { restore(read_checkpoint(path), path); }

  // OUT/gaussians.ply, OUT/env.exr, OUT/log.csv (plus OUT/env_<type>.json for an
  // environment whose parameters the image does not carry -- env_sg.json with SGs
  // -- and OUT/mesh_materials.json when mesh materials are optimised); each atomic.
  // (optimizer_outputs.cpp; checkpoint()/restore()/run_optimizer in
  // optimizer_checkpoint.cpp; fingerprint() in optimizer_fingerprint.cpp.)
  void write_outputs(const std::string& dir) const;
  std::string log_csv() const;
  // The recovered environment as a lat-long RGB image (a lat-long
  // map's own texels; other models rasterised at env_width x env_height).
  Image environment_image() const;

  const Scene& scene() const { return *scene_; }
  Scene& scene() { return *scene_; }
  const PathTracer& tracer() const { return *tracer_; }
  const Dataset& dataset() const { return *dataset_; }
  std::shared_ptr<const Dataset> dataset_ptr() const { return dataset_; }
  const Parameters& parameters() const { return params_; }
  // What the known map's alignment found (mode off: none ran); OUT/settings.json "env_align".
  const EnvAlignResult& env_alignment() const { return env_align_; }
  const std::vector<Adam>& adam() const { return adam_; }
  const std::vector<IterationLog>& log() const { return log_; }
  size_t nonfinite_gradients() const { return nonfinite_; }

  // The views and crop windows iteration `it` (0-based) uses: (view index, x0, y0, w, h).
  struct ViewPick {
    size_t view;
    int x0, y0, w, h;  // window of the (reduced) view
    int factor = 1;    // the view reduced by this factor (view_pyramid.h)
  };
  std::vector<ViewPick> pick_views(int it) const;
  // The pyramid's reduction factor of iteration `it` (1: full resolution); its coarse
  // factor (1: these views are not reduced) and the share of the iterations at it.
  int pyramid_level_factor(int it) const;
  int pyramid_coarse_factor() const;
  // Samples per pixel of an iteration at reduction factor f (coarse_spp for f > 1).
  int spp_at(int f) const { return f > 1 && settings_.coarse_spp > 0 ? settings_.coarse_spp : settings_.integrator.spp; }
  double pyramid_coarse_share() const { return pyramid_coarse_factor() > 1 ? 1.0 - double(settings_.fine_fraction) : 0.0; }
  // Views and crop side of an iteration at reduction factor f (the batch resolved for that level).
  std::pair<int, int> batch_at(int f) const;

 private:
  struct ViewWork;  // one view of an iteration (optimizer.cpp)
  struct Primal;    // one primal render and its replay cache (optimizer.cpp)
  // part: which of the view's primal renders (0, or 1 for the second decorrelated half).
  Primal primal(const ViewWork& w, const IntegratorSettings& is, bool with_gradients, size_t cache_bytes, int part,
                const RenderControl& control, IterationLog& log) const;
  void apply();
  // Mode search on masked photos: the fixed known map's level from short inversions
  // at a few candidate levels (env_align.h; optimizer_known_level.cpp).
  void search_known_level();
  const std::array<int, 4>& mask_box(size_t view) const;
  std::array<int, 4> mask_box(size_t view, int f) const;  // of the view reduced by f
  // The training image of view `view` reduced by f (cached for the current factor).
  std::shared_ptr<const TrainingImage> reduced_target(size_t view, int f) const;
  ViewWork view_work(int it, size_t v, const ViewPick& pick) const;
  float loss_encode(float c) const;             // linear -> loss space
  float loss_encode_derivative(float c) const;
  // The image loss of one view (and its gradient through the path replay), then
  // the regularisers on its primary-hit material maps; both add to `log`.
  void image_term(const ViewWork& w, float inv_k, bool with_gradients, const RenderControl& control, IterationLog& log);
  void regulariser_terms(const ViewWork& w, float inv_k, bool with_gradients, const RenderControl& control,
                         IterationLog& log);

  OptimizerSettings settings_;
  std::unique_ptr<Scene> scene_;
  std::shared_ptr<const Dataset> dataset_;
  std::unique_ptr<PathTracer> tracer_;
  Parameters params_;
  EnvAlignResult env_align_;
  std::vector<Adam> adam_;
  SceneGradients grads_;
  std::vector<IterationLog> log_;
  int iteration_ = 0;
  size_t nonfinite_ = 0;
  std::array<double, 3> balance_grad_{};  // dL/d balance of the image terms (light_balance.h)
  ExposureGradients exposure_grads_;  // --learn-exposure (exposure.h)
  mutable std::vector<std::array<int, 4>> mask_box_;  // per view: x0, y0, x1, y1 (x1 < x0: not computed)
  bool auto_batch_ = false;
  bool auto_views_ = false;  // the patch count was automatic (the budget's plan may set it)  // the batch was automatic (resolved per pyramid level)
  mutable int reduced_factor_ = 1;
  mutable std::vector<std::shared_ptr<const TrainingImage>> reduced_;  // per view, at reduced_factor_
  // The primal renders' kept walks, per part and row band (memory reused from one
  // iteration to the next; walk_store.h).
  mutable std::array<std::vector<std::unique_ptr<WalkStore>>, 2> walk_stores_;
  const Communicator* comm_ = &single_process();      // data-parallel runs (set_communicator)
};

// The loop with checkpoints and outputs, for the CLI and the Python module.
struct RunOptions {
  std::string out_dir;        // outputs and checkpoint.bin go here ("" = write nothing)
  int checkpoint_every = 50;  // iterations between checkpoints (0: only at the end)
  // Called after every iteration; return false to stop (as a cancel).
  std::function<bool(const IterationLog&)> on_iteration;
  const std::atomic<bool>* cancel = nullptr;
};


// Runs until settings().iterations; on cancel (flag or callback) stops after the
// last completed iteration. Either way writes OUT/checkpoint.bin and the outputs.
RunResult run_optimizer(Optimizer& opt, const RunOptions& options);

}  // namespace ptir
