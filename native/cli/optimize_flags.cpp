// The inversion's learning options of `ptir optimize` (optimize_flags.h).
#include "optimize_flags.h"

namespace ptir::cli {

void add_learning_flags(CLI::App* cmd, OptimizeOptions* opt) {
  cmd->add_option("--loss-space", opt->loss_space, "compare images in srgb-blur-first (the sRGB of the render after the loss's 3x3 blur, not before: its noise biases the loss 7x less), srgb (the sRGB of each pixel, then the blur) or linear space; a resumed run keeps its own")->capture_default_str();
  cmd->add_option("--lambda-tv", opt->lambda_tv, "weight of the edge-aware TV regulariser")->capture_default_str();
  cmd->add_option("--tv-chroma", opt->tv_chroma,
                  "the albedo TV's edges from the target's chromaticity at this sharpness (a shadow edge is smoothed, "
                  "a colour edge is not); 0: from its intensity (PTIR's, with --lambda-tv 0.095)")
      ->capture_default_str();
  cmd->add_option("--lr-final", opt->lr_final,
                  "learning rate at the last iteration, as a fraction of the initial one (1: constant)")
      ->capture_default_str();
  cmd->add_option("--lr-decay-start", opt->lr_decay_start,
                  "fraction of the iterations after which the learning rate decays (exponentially)")
      ->capture_default_str();
  cmd->add_option("--sample-cache-mb", opt->sample_cache_mb,
                  "memory for what each sample's replay reuses from its primal (radiance, ray outcomes, walks); "
                  "beyond it the replay traces again (same results)")
      ->capture_default_str();
  cmd->add_option("--env-coarse", opt->env_coarse,
                  "lat-long environment: width of a coarse level learnt with the texels (coarse-to-fine; 0: none; -1: 1/8 of the map's width)")
      ->capture_default_str();
  cmd->add_option("--albedo-warmup", opt->albedo_warmup,
                  "fraction of the iterations over which the albedo learning rates ramp up from 0 (light first); -1: "
                  "automatic (0.5; 0 when the --scene file's lamps light the scene besides a learnt environment, "
                  "which then starts dark)")
      ->capture_default_str();
  cmd->add_option("--tv-warmup", opt->tv_warmup,
                  "the TV weight starts at this multiple of --lambda-tv and falls to it at half the iterations")
      ->capture_default_str();
  cmd->add_option("--init-albedo", opt->init_albedo, "the Gaussians' starting albedo (linear, every channel)")
      ->capture_default_str();
  cmd->add_flag("--init-from-ply", opt->init_from_ply,
                "start albedo, roughness (and metallic) from the input PLY's albedo_*, roughness, metallic "
                "(a previous result to refine); without them the defaults apply");
  cmd->add_option("--light-balance", opt->light_balance,
                  "learn the light-albedo balance: one scale per channel moving all albedos against the environment (lat-long)")
      ->capture_default_str();
  cmd->add_option("--decorrelate-adjoint", opt->decorrelate_adjoint,
                  "weight each half of the samples' gradient by the image loss of the other, independent half (unbiased by the render's noise)")
      ->capture_default_str();
  cmd->add_option("--lambda-ssim", opt->lambda_ssim, "D-SSIM's weight in the image loss ((1 - w) L1 + w (1 - SSIM))")
      ->capture_default_str();
  cmd->add_option("--loss-blur", opt->loss_blur, "blur the render by a 3x3 binomial filter before the image loss (PTIR's noise suppression)")
      ->capture_default_str();
  cmd->add_option("--loss-blur-target", opt->loss_blur_target,
                  "with --loss-blur: blur the target image the same way (the optimum is then the unblurred match)")
      ->capture_default_str();
  cmd->add_option("--lr-balance", opt->lr_balance, "the light-albedo balance's Adam learning rate")->capture_default_str();
  cmd->add_option("--lambda-albedo-grey", opt->lambda_albedo_grey,
                  "grey-world prior on the albedos' mean colour, along the light-albedo balance only (0: off)")
      ->capture_default_str();
  cmd->add_option("--balance-start", opt->balance_start, "fraction of the iterations before the light-albedo balance learns")
      ->capture_default_str();
  cmd->add_option("--lr-env", opt->lr_env, "the environment's Adam learning rate (its log radiance per step)")
      ->capture_default_str();
  cmd->add_option("--lr-albedo", opt->lr_albedo, "the Gaussians' albedo Adam learning rate (logit per step)")
      ->capture_default_str();
  cmd->add_option("--lr-metallic", opt->lr_metallic,
                  "the Gaussians' metallic Adam learning rate (logit per step; with --optimize-metallic)")
      ->capture_default_str();
  cmd->add_option("--lr-roughness", opt->lr_roughness, "the Gaussians' roughness Adam learning rate (logit per step)")
      ->capture_default_str();
  cmd->add_option("--env-fine-rate", opt->env_fine_rate,
                  "with a coarse level: the fine texels' rate as a fraction of --lr-env (the coarse level's)")
      ->capture_default_str();
  cmd->add_option("--neutral-light", opt->neutral_light,
                  "keep the learnt environment's colour neutral, its colour going into the albedos (default: on "
                  "without --dataset, where baked radiance fixes only albedo x light; off with photos)");
  cmd->add_flag("--optimize-metallic", opt->optimize_metallic, "also optimise metallic (default: fixed 0)");
  cmd->add_flag("--optimize-meshes", opt->optimize_meshes, "also optimise the --scene meshes' materials");
  cmd->add_flag("--learn-exposure", opt->learn_exposure,
                "learn one exposure scale per training image (photos without EXIF exposure); OUT/exposure.json");
}

std::set<std::string> given_options(const CLI::App& cmd) {
  std::set<std::string> given;
  for (const CLI::Option* option : cmd.get_options())
    if (option->count() > 0)
      for (const std::string& name : option->get_lnames()) given.insert("--" + name);
  return given;
}

}  // namespace ptir::cli
