// The optimiser's fingerprint: the inputs and settings a checkpoint must match
// to be resumed (checkpoint.h). Values are text; the keys and their texts are
// part of the checkpoint format, so existing entries keep their spelling.
#include <cstring>
#include <filesystem>
#include <functional>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/core/number_text.h"
#include "ptir/math/rng.h"
#include "ptir/optim/optimizer.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

std::string num(double v) { return num_text(v); }

uint64_t hash_floats(uint64_t h, const float* p, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    uint32_t bits;
    std::memcpy(&bits, &p[i], 4);
    h = hash_combine(h, bits);
  }
  return h;
}

// The learnable environment's settings: "latlong WxH init", "sg N", "color init", "none".
std::string env_settings_text(const ParameterSettings& ps) {
  switch (ps.env) {
    case EnvMode::LatLong:
      return "latlong " + std::to_string(ps.env_width) + "x" + std::to_string(ps.env_height) + " " + num(ps.env_init);
    case EnvMode::SG: return "sg " + std::to_string(ps.sg_lobes);
    case EnvMode::Constant: return "color " + num(ps.env_init);
    case EnvMode::None: return "none";
  }
  return "?";
}

}  // namespace

Fingerprint Optimizer::fingerprint() const {
  const GaussianField& f = *scene_->gaussians;
  const IntegratorSettings& is = settings_.integrator;
  const ParameterSettings& ps = settings_.params;
  uint64_t geo = 0;
  geo = hash_floats(geo, reinterpret_cast<const float*>(f.position.data()), 3 * f.size());
  geo = hash_floats(geo, reinterpret_cast<const float*>(f.scale.data()), 3 * f.size());
  geo = hash_floats(geo, reinterpret_cast<const float*>(f.rotation.data()), 4 * f.size());
  geo = hash_floats(geo, f.opacity.data(), f.size());
  for (const TriangleMesh& m : scene_->meshes) geo = hash_floats(geo, reinterpret_cast<const float*>(m.vertices.data()), 3 * m.vertices.size());
  uint64_t views = 0;
  for (const DatasetView& v : dataset_->views) {
    views = hash_combine(views, std::hash<std::string>()(v.camera.name));
    views = hash_floats(views, &v.camera.cam_to_world.linear.m[0][0], 9);
    views = hash_floats(views, &v.camera.cam_to_world.translation.x, 3);
  }
  std::ostringstream hx, hv;
  hx << std::hex << geo;
  hv << std::hex << views;
  Fingerprint fp = {
      {"gaussians", std::to_string(f.size())},
      {"meshes", std::to_string(scene_->meshes.size())},
      {"lights", std::to_string(scene_->emitters.size())},
      {"geometry_hash", hx.str()},
      {"views", std::to_string(dataset_->size())},
      {"views_hash", hv.str()},
      {"image_size", std::to_string(dataset_->width) + "x" + std::to_string(dataset_->height)},
      {"priors", dataset_->has_priors() ? "yes" : "no"},
      {"seed", std::to_string(settings_.seed)},
      {"spp", std::to_string(is.spp)},
      {"bounces", std::to_string(is.max_bounces)},
      // v1 keeps the name checkpoints carried before v2 existed, so they still resume.
      {"brdf", is.brdf == BsdfModel::PrincipledV1 ? std::string("principled") : std::string(to_string(is.brdf))},
      {"min_specular_probability", num(is.min_specular_probability)},
      {"interaction", interaction_mode_name(is.interaction.mode)},
      {"tau_g", num(is.interaction.tau_g)},
      {"geometric_criterion", is.geometric_criterion ? "1" : "0"},
      {"self_intersection", self_intersection_name(is.self_intersection)},
      {"k", std::to_string(settings_.accel.k)},
      {"views_per_iteration", std::to_string(settings_.views_per_iteration)},
      {"crop", std::to_string(settings_.crop_size)},
      {"loss", num(settings_.loss.lambda_ssim) + (settings_.loss.binomial_filter ? " blur" : " noblur") +
                   (settings_.loss.binomial_filter && settings_.loss.blur_target ? " target" : "") +
                   (settings_.srgb_loss ? (settings_.srgb_after_blur ? " srgb-blur-first" : " srgb") : " linear")},
      {"mask_threshold", num(settings_.mask_threshold)},
      {"lambda_tv", num(settings_.lambda_tv)},
      {"prior", num(settings_.prior_start) + " " + num(settings_.prior_end) + " " + std::to_string(settings_.prior_iterations)},
      {"init", num(ps.init_albedo) + " " + num(ps.init_roughness) + " " + num(ps.init_metallic) + " " +
                   num(ps.init_metallic_optimised) + (ps.init_from_field ? " from the input" : "")},
      {"metallic", ps.optimize_metallic ? "optimised" : "fixed"},
      {"env", env_settings_text(ps)},
      {"env_init", (ps.env_init_path.empty() ? std::string("constant") : fs::absolute(ps.env_init_path).string()) +
                       (ps.env_init_seen_fixed    ? " (seen texels fixed)"
                        : ps.env_init_seen_coarse ? " (seen texels: coarse change only)"
                                                  : "")},
      {"env_optimised", ps.optimize_env && ps.env != EnvMode::None ? "1" : "0"},
      {"mesh_materials", ps.optimize_meshes ? "optimised" : "fixed"},
      {"exposure", ps.learn_exposure ? "learned" : "fixed"},
      {"lr", num(ps.lr_albedo) + " " + num(ps.lr_roughness) + " " + num(ps.lr_metallic) + " " + num(ps.lr_env) + " " +
                 num(ps.lr_mesh) + (ps.env_fine_lr_scale != 1.0f ? " fine " + num(ps.env_fine_lr_scale) : std::string())},
      {"lr_schedule", num(settings_.lr_final) + " from " + num(settings_.lr_decay_start)},
      {"env_coarse", std::to_string(ps.env_coarse_width)},
      {"warmup", num(settings_.albedo_warmup) + " tv " + num(settings_.tv_warmup)},
      // (no environment: no balance to learn, the scene's lights hold the level)
      {"light balance", ps.env == EnvMode::None ? std::string("off (no environment)") : settings_.light_balance ? "on " + num(ps.lr_balance) + " from " + num(settings_.balance_start) +
                                                (settings_.lambda_albedo_grey > 0.0f ? ", grey prior " + num(settings_.lambda_albedo_grey) : std::string()) : std::string("off")},
      {"adam", num(settings_.adam.beta1) + " " + num(settings_.adam.beta2) + " " + num(settings_.adam.eps)},
      {"adjoint", settings_.decorrelate_adjoint ? "decorrelated" : "same samples"},
      {"orient_normals", settings_.orient_normals ? "1" : "0"},
  };
  // Only then: checkpoints of path-traced bounce light (and from before) still resume.
  if (is.indirect_from_field) fp.push_back({"indirect", "field"});
  if (settings_.neutral_light) fp.push_back({"light", "neutral"});
  if (settings_.tv_chroma > 0.0f) fp.push_back({"tv_guide", "chroma " + num(settings_.tv_chroma)});
  // Real captures read at a working size or their common size (dataset.h): the photos' own size and
  // what was done (absent where the photos are read as stored, so older checkpoints still resume).
  if (!dataset_->size_note.empty()) fp.push_back({"photos", dataset_->size_note});
  if (settings_.background_loss) fp.push_back({"background_loss", "object share " + num(settings_.object_patch_share)});
  if (settings_.coarse_pixels > 0)
    fp.push_back({"pyramid", std::to_string(settings_.coarse_pixels) + " until " + num(1.0f - settings_.fine_fraction) +
                                 (spp_at(2) != is.spp ? ", coarse spp " + std::to_string(spp_at(2)) : std::string())});
  return fp;
}

// Options measured, lost and removed (docs/inversion.md) left these entries in
// checkpoints written before their removal. At the values the removed options'
// defaults wrote they are dropped (such a run resumes: it ran the code that is
// left); any other value names an option this binary no longer has.
void retire_fingerprint_entries(const std::string& path, Fingerprint& stored) {
  const std::string off = num(0.0);
  auto refuse = [&](const std::string& option) {
    throw Error(path, "checkpoint was written with " + option + ", which was measured, lost and removed " +
                          "(docs/inversion.md); ptir at commit " + kLastCommitWithRetiredOptions +
                          " still resumes it (git checkout " + kLastCommitWithRetiredOptions + ")");
  };
  Fingerprint kept;
  for (auto& kv : stored) {
    const std::string& k = kv.first;
    std::string& v = kv.second;
    if (k == "light solve") refuse("--light-solve");
    if (k == "huber") {
      if (v != off) refuse("--huber-delta " + v);
      continue;
    }
    if (k == "env_adam") {
      if (v != "texel") refuse("--env-adam " + v);
      continue;
    }
    if (k == "environment prior") {
      if (v != "smooth " + off + " chroma " + off + " fine warmup " + off)
        refuse("--lambda-env-smooth, --lambda-env-chroma or --env-fine-warmup (" + v + ")");
      continue;
    }
    if (k == "loss") {
      if (v.find(" srgb-tangent") != std::string::npos) refuse("--loss-space srgb-tangent");
      if (v.find(" cross ssim") != std::string::npos) refuse("--ssim-cross 1");
    }
    kept.push_back(kv);
  }
  stored.swap(kept);
}

}  // namespace ptir
