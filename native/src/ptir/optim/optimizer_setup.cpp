#include "ptir/optim/optimizer_setup.h"

#include "ptir/core/error.h"
#include "ptir/scene/scene_json.h"

namespace ptir {

std::string cli_option_name(const std::string& snake_case) {
  std::string s = "--" + snake_case;
  for (char& c : s)
    if (c == '_') c = '-';
  return s;
}

std::string python_option_name(const std::string& snake_case) { return snake_case; }

OptimizerSettings optimizer_settings(const OptimizeOptions& o, const OptionNames& names) {
  if (o.iters < 0) throw Error(names("iters") + " must be >= 0");
  if (o.spp < 1) throw Error(names("spp") + " must be at least 1");
  if (o.bounces < 0) throw Error(names("bounces") + " must be at least 0");
  OptimizerSettings s;
  s.iterations = o.iters;
  s.integrator.spp = o.spp;
  s.integrator.max_bounces = o.bounces;
  if (o.indirect != "auto" && o.indirect != "path" && o.indirect != "field")
    throw Error(names("indirect") + " must be 'auto', 'path' or 'field', got '" + o.indirect + "'");
  s.integrator.indirect_from_field = o.indirect == "field";
  s.seed = o.seed;
  s.views_per_iteration = o.views_per_iter;
  s.crop_size = o.crop;
  if (o.coarse_pixels < 0) throw Error(names("coarse_pixels") + " must be >= 0 (0: no resolution pyramid)");
  if (!(o.fine_fraction >= 0.0f && o.fine_fraction <= 1.0f)) throw Error(names("fine_fraction") + " must be in [0, 1]");
  s.coarse_pixels = o.coarse_pixels;
  s.fine_fraction = o.fine_fraction;
  if (o.coarse_spp < 0) throw Error(names("coarse_spp") + " must be >= 0 (0: the same as " + names("spp") + ")");
  s.coarse_spp = o.coarse_spp;
  s.lambda_tv = o.lambda_tv;
  if (!(o.tv_chroma >= 0.0f)) throw Error(names("tv_chroma") + " must be >= 0 (0: the intensity guide)");
  s.tv_chroma = o.tv_chroma;
  if (o.background_loss != "auto" && o.background_loss != "on" && o.background_loss != "off")
    throw Error(names("background_loss") + " must be auto, on or off, got '" + o.background_loss + "'");
  s.background_loss = o.background_loss == "on";
  if (!(o.object_patch_share >= 0.0f && o.object_patch_share <= 1.0f))
    throw Error(names("object_patch_share") + " must be in [0, 1]");
  s.object_patch_share = o.object_patch_share;
  if (!(o.lr_final > 0.0f && o.lr_final <= 1.0f)) throw Error(names("lr_final") + " must be in (0, 1]");
  if (!(o.lr_decay_start >= 0.0f && o.lr_decay_start < 1.0f)) throw Error(names("lr_decay_start") + " must be in [0, 1)");
  s.lr_final = o.lr_final;
  s.lr_decay_start = o.lr_decay_start;
  if (o.sample_cache_mb < 0) throw Error(names("sample_cache_mb") + " must be >= 0");
  s.sample_cache_bytes = size_t(o.sample_cache_mb) << 20;
  if (!(o.lr_env > 0.0f)) throw Error(names("lr_env") + " must be > 0");
  s.params.lr_env = o.lr_env;
  if (!(o.lr_albedo > 0.0f)) throw Error(names("lr_albedo") + " must be > 0");
  s.params.lr_albedo = o.lr_albedo;
  // 0 keeps roughness at its start (optimize without --dataset on SH degree 0: nothing constrains it).
  if (!(o.lr_roughness >= 0.0f)) throw Error(names("lr_roughness") + " must be >= 0 (0: roughness fixed)");
  s.params.lr_roughness = o.lr_roughness;
  if (!(o.lr_metallic > 0.0f)) throw Error(names("lr_metallic") + " must be > 0");
  s.params.lr_metallic = o.lr_metallic;
  if (!(o.env_fine_rate > 0.0f && o.env_fine_rate <= 1.0f)) throw Error(names("env_fine_rate") + " must be in (0, 1]");
  s.params.env_fine_lr_scale = o.env_fine_rate;
  if (!(o.init_albedo > 0.0f && o.init_albedo < 1.0f)) throw Error(names("init_albedo") + " must be in (0, 1)");
  s.params.init_albedo = o.init_albedo;
  s.params.init_from_field = o.init_from_ply;
  if (!(o.lr_balance > 0.0f)) throw Error(names("lr_balance") + " must be > 0");
  s.light_balance = o.light_balance;
  s.neutral_light = o.neutral_light;
  s.params.lr_balance = o.lr_balance;
  if (!(o.balance_start >= 0.0f && o.balance_start < 1.0f)) throw Error(names("balance_start") + " must be in [0, 1)");
  s.balance_start = o.balance_start;
  if (!(o.lambda_albedo_grey >= 0.0f)) throw Error(names("lambda_albedo_grey") + " must be >= 0");
  s.lambda_albedo_grey = o.lambda_albedo_grey;
  if (o.env_coarse < -1) throw Error(names("env_coarse") + " must be >= 0 (0: no coarse level; -1: automatic)");
  s.params.env_coarse_width = o.env_coarse;
  if (!(o.albedo_warmup == -1.0f || (o.albedo_warmup >= 0.0f && o.albedo_warmup < 1.0f)))
    throw Error(names("albedo_warmup") + " must be in [0, 1) (or -1: automatic)");
  if (!(o.tv_warmup >= 1.0f)) throw Error(names("tv_warmup") + " must be >= 1");
  s.albedo_warmup = o.albedo_warmup;
  s.tv_warmup = o.tv_warmup;
  s.decorrelate_adjoint = o.decorrelate_adjoint;
  if (!(o.lambda_ssim >= 0.0f && o.lambda_ssim <= 1.0f)) throw Error(names("lambda_ssim") + " must be in [0, 1]");
  s.loss.lambda_ssim = o.lambda_ssim;
  s.loss.binomial_filter = o.loss_blur;
  s.loss.blur_target = o.loss_blur_target;
  s.accel.k = o.k;
  if (o.loss_space == "srgb" || o.loss_space == "srgb-blur-first") s.srgb_loss = true;
  else if (o.loss_space == "linear") s.srgb_loss = false;
  else throw Error(names("loss_space") + " must be 'srgb-blur-first', 'srgb' or 'linear', got '" + o.loss_space + "'");
  s.srgb_after_blur = o.loss_space == "srgb-blur-first";  // (also the engine default, optimizer.h)
  s.params.env = parse_env_mode(o.env, names("env"));
  if (s.params.env == EnvMode::None && !o.env_init.empty())
    throw Error(names("env_init") + " needs an environment model (" + names("env") + " none has no environment)");
  if (o.env_width < 1 || o.env_height < 1) throw Error(names("env_size") + " must be positive");
  s.params.env_width = o.env_width;
  s.params.env_height = o.env_height;
  s.params.env_init_path = o.env_init;
  s.params.optimize_env = !o.fix_env;
  if (o.env_seen != "auto" && o.env_seen != "learn" && o.env_seen != "coarse" && o.env_seen != "fixed")
    throw Error(names("env_seen") + " must be auto, learn, coarse or fixed, got '" + o.env_seen + "'");
  s.params.env_init_seen_fixed = o.fix_env_seen || o.env_seen == "fixed";
  s.params.env_init_seen_coarse = o.env_seen == "coarse" && !s.params.env_init_seen_fixed;
  if ((s.params.env_init_seen_fixed || s.params.env_init_seen_coarse) && o.env_init.empty())
    throw Error(names(o.fix_env_seen ? "fix_env_seen" : "env_seen") + " needs " + names("env_init") +
                " (a map whose alpha marks the seen texels)");
  if (o.fix_env && o.env_init.empty())
    throw Error(names("fix_env") + " needs " + names("env_init") + " (the known environment map)");
  s.env_align.mode = parse_env_align_mode(o.env_align, names("env_align"));
  s.env_align.map_fixed = o.fix_env;
  if (o.env_init.empty() || s.params.env_init_seen_fixed || s.params.env_init_seen_coarse)
    s.env_align.mode = EnvAlignMode::Off;
  if (o.env_refine) {
    if (o.env_init.empty()) throw Error(names("env_refine") + " needs " + names("env_init") + " (the map to refine)");
    if (o.fix_env) throw Error("give " + names("env_refine") + " or " + names("fix_env") + ", not both");
    s.params.lr_env *= kEnvRefineRate;
  }
  s.params.optimize_metallic = o.optimize_metallic;
  s.params.optimize_meshes = o.optimize_meshes;
  s.params.learn_exposure = o.learn_exposure;
  return s;
}

namespace {

// Light other than the environment: a lamp, or a mesh that emits.
bool has_own_light(const Scene& scene) {
  if (!scene.emitters.empty()) return true;
  for (const TriangleMesh& m : scene.meshes)
    if (m.material.emission.x > 0.0f || m.material.emission.y > 0.0f || m.material.emission.z > 0.0f) return true;
  return false;
}

}  // namespace

Scene prepare_optimizer_scene(const std::string& scene_path, std::shared_ptr<GaussianField> field, OptimizerSettings& s,
                              const OptionNames& names, const std::function<void(const std::string&)>& note) {
  Scene scene;
  if (!scene_path.empty()) {
    scene = load_scene_json(scene_path);
    if (scene.gaussians && scene.gaussians->size() > 0)
      throw Error(scene_path, "the scene file has Gaussians; give them with " + names("gaussians") +
                                  " instead (the optimiser's Gaussians come from one PLY)");
    if (scene.environment.present() && note)
      note(s.params.env == EnvMode::None ? "the scene's environment is ignored: " + names("env") + " none (its lights alone)"
                                         : "the scene's environment is ignored: the environment is what gets recovered");
    // Recovered mesh materials are constants: a textured input would ignore them.
    for (const TriangleMesh& m : scene.meshes)
      if (s.params.optimize_meshes && m.material.textured())
        throw Error(scene_path, "mesh '" + m.name + "' has image textures; " + names("optimize_meshes") +
                                    " recovers constant materials only (leave that mesh's material out)");
    const IntegratorSettings& is = scene.integrator;
    s.integrator.interaction = is.interaction;
    s.integrator.geometric_criterion = is.geometric_criterion;
    s.integrator.self_intersection = is.self_intersection;
    s.integrator.self_range_scale = is.self_range_scale;
    s.integrator.fixed_offset = is.fixed_offset;
    s.integrator.fixed_range = is.fixed_range;
    s.integrator.brdf = is.brdf;
  } else if (s.params.optimize_meshes) {
    throw Error(names("optimize_meshes") + " needs " + names("scene") + " (the meshes come from the scene file)");
  }
  // The scene's own light and a learnt environment: the environment starts dark and the albedos
  // learn at once, so the environment does not take the lamps' light (kSceneLitEnvStart).
  const bool lit = has_own_light(scene), learnt_env = s.params.env != EnvMode::None;
  if (s.albedo_warmup < 0.0f) s.albedo_warmup = lit && learnt_env ? 0.0f : OptimizerSettings{}.albedo_warmup;
  if (lit && learnt_env && s.params.env_init_path.empty()) s.params.env_init = kSceneLitEnvStart;
  if (s.params.env == EnvMode::None && !lit)
    throw Error((scene_path.empty() ? std::string() : scene_path + ": ") + names("env") +
                " none leaves the scene file's lights and emissive meshes as the only light, and " +
                (scene_path.empty() ? "there is no " + names("scene") : std::string("it has none")));
  scene.gaussians = std::move(field);
  scene.source_path = scene_path.empty() ? "command line" : scene_path;
  return scene;
}

}  // namespace ptir
