#include "ptir/optim/parameters.h"

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"
#include "ptir/io/image.h"
#include "ptir/optim/env_pyramid.h"

namespace ptir {

float logit_clamped(float p) {
  p = std::clamp(p, 1e-6f, 1.0f - 1e-6f);
  return std::log(p / (1.0f - p));
}

float roughness_to_raw(float r) { return logit_clamped((r - kRoughnessMin) / kRoughnessRange); }

const char* param_kind_name(ParamKind k) {
  switch (k) {
    case ParamKind::GaussianAlbedo: return "albedo";
    case ParamKind::GaussianRoughness: return "roughness";
    case ParamKind::GaussianMetallic: return "metallic";
    case ParamKind::Environment: return "environment";
    case ParamKind::MeshColour: return "mesh_base_colour";
    case ParamKind::MeshRoughness: return "mesh_roughness";
    case ParamKind::MeshMetallic: return "mesh_metallic";
    case ParamKind::EnvironmentCoarse: return "environment_coarse";
    case ParamKind::Exposure: return "exposure";
    case ParamKind::GaussianPosition: return "position";
    case ParamKind::GaussianLogScale: return "log_scale";
    case ParamKind::GaussianRotation: return "rotation";
    case ParamKind::GaussianOpacity: return "opacity";
    case ParamKind::GaussianShDc: return "sh_dc";
    case ParamKind::GaussianShRest: return "sh_rest";
    case ParamKind::GaussianNormal: return "normal";
    case ParamKind::FitStatistics: return "fit_statistics";
    case ParamKind::FitLogRows: return "fit_log";
    case ParamKind::LightBalance: return "light_balance";
  }
  return "?";
}

const ParameterGroup* Parameters::find(ParamKind k) const {
  for (const ParameterGroup& g : groups)
    if (g.kind == k) return &g;
  return nullptr;
}

ParameterGroup* Parameters::find(ParamKind k) {
  for (ParameterGroup& g : groups)
    if (g.kind == k) return &g;
  return nullptr;
}

size_t Parameters::count() const {
  size_t n = 0;
  for (const ParameterGroup& g : groups) n += g.raw.size();
  return n;
}

const char* env_mode_name(EnvMode m) {
  switch (m) {
    case EnvMode::LatLong: return "latlong";
    case EnvMode::SG: return "sg";
    case EnvMode::Constant: return "color";
    case EnvMode::None: return "none";
  }
  return "?";
}

EnvMode parse_env_mode(const std::string& name, const std::string& what) {
  for (EnvMode m : {EnvMode::LatLong, EnvMode::SG, EnvMode::Constant, EnvMode::None})
    if (name == env_mode_name(m)) return m;
  throw Error(what + " must be 'latlong', 'sg', 'color' or 'none', got '" + name + "'");
}

void install_environment(Scene& scene, const ParameterSettings& s) {
  scene.environment = SceneEnvironment();
  if (s.env == EnvMode::None) {  // black: the scene's own lights alone
    if (!s.env_init_path.empty()) throw Error(s.env_init_path, "an initial environment map needs an environment model, not none");
    return;
  }
  if (!s.env_init_path.empty()) {
    if (s.env != EnvMode::LatLong) throw Error(s.env_init_path, "an initial environment map needs the lat-long environment model");
    Environment env = Environment::load(s.env_init_path);
    // Texels are exp(raw): keep them strictly positive.
    for (float& t : env.texels()) t = std::max(t, 1e-6f);
    env.rebuild_sampling();
    scene.environment = std::move(env);
  } else if (s.env == EnvMode::LatLong) {
    if (s.env_width < 1 || s.env_height < 1) throw Error("environment size must be positive");
    if (!(s.env_init > 0.0f)) throw Error("initial environment radiance must be positive (texels are exp(raw))");
    scene.environment = Environment::constant(Vec3(s.env_init), s.env_width, s.env_height);
  } else if (s.env == EnvMode::SG) {
    if (s.sg_lobes < 1) throw Error("the SG environment needs at least one lobe");
    scene.environment = SgEnvironment(s.sg_lobes);
  } else {
    if (!(s.env_init > 0.0f)) throw Error("initial environment radiance must be positive (the colour is exp(raw))");
    scene.environment = ConstantEnvironment(Vec3(s.env_init));
  }
}

namespace {

// The env_init map's seen texels (alpha > 0.5) as log radiance, NaN elsewhere.
std::vector<float> known_environment(const Scene& scene, const ParameterSettings& s) {
  const Environment* env = scene.environment.as<Environment>();
  if (!env || s.env_init_path.empty()) throw Error("the seen environment texels need a lat-long --env-init map");
  const Image map = read_image(s.env_init_path);
  if (map.channels < 4) throw Error(s.env_init_path, "has no alpha channel to say which texels were seen");
  if (map.width != env->width() || map.height != env->height()) throw Error(s.env_init_path, "size differs from the environment's");
  std::vector<float> known(size_t(map.width) * size_t(map.height) * 3, std::nanf(""));
  for (size_t t = 0; t < known.size() / 3; ++t)
    if (map.pixels[size_t(map.channels) * t + 3] > 0.5f)
      for (int c = 0; c < 3; ++c) known[3 * t + size_t(c)] = std::log(std::max(env->texels()[3 * t + size_t(c)], 1e-6f));
  return known;
}

}  // namespace

Parameters make_parameters(const Scene& scene, const ParameterSettings& s) {
  Parameters p;
  const size_t n = scene.gaussians->size();
  p.groups.push_back({ParamKind::GaussianAlbedo, s.lr_albedo, std::vector<float>(3 * n, logit_clamped(s.init_albedo))});
  p.groups.push_back({ParamKind::GaussianRoughness, s.lr_roughness, std::vector<float>(n, roughness_to_raw(s.init_roughness))});
  if (s.optimize_metallic)
    p.groups.push_back({ParamKind::GaussianMetallic, s.lr_metallic, std::vector<float>(n, logit_clamped(s.init_metallic_optimised))});
  if (s.init_from_field) {
    const GaussianField& f = *scene.gaussians;
    for (ParameterGroup& g : p.groups) {
      for (size_t i = 0; i < n; ++i) {
        if (g.kind == ParamKind::GaussianAlbedo)
          for (int c = 0; c < 3; ++c) g.raw[3 * i + c] = logit_clamped(f.albedo[i][c]);
        else if (g.kind == ParamKind::GaussianRoughness)
          g.raw[i] = roughness_to_raw(f.roughness[i]);
        else if (g.kind == ParamKind::GaussianMetallic)
          g.raw[i] = logit_clamped(std::max(f.metallic[i], s.init_metallic_optimised));
      }
    }
  }
  if ((s.env_init_seen_fixed || s.env_init_seen_coarse) && s.optimize_env) {
    p.env_known = known_environment(scene, s);
    p.env_known_coarse = !s.env_init_seen_fixed;
  }
  // Fixed lighting (or none): no group.
  if (s.optimize_env && scene.environment.present()) {
    std::vector<float> raw(scene.environment.parameter_count());
    scene.environment->get_raw(raw.data());
    const Environment* latlong = scene.environment.as<Environment>();
    const int cw = !latlong ? 0 : s.env_coarse_width >= 0 ? s.env_coarse_width : latlong->width() >= 32 ? latlong->width() / 8 : 0;
    p.groups.push_back({ParamKind::Environment, cw > 0 ? s.lr_env * s.env_fine_lr_scale : s.lr_env, std::move(raw)});
    if (cw > 0) {
      const int ch = std::max(1, cw / 2);
      p.groups.push_back({ParamKind::EnvironmentCoarse, s.lr_env, std::vector<float>(size_t(cw) * ch * 3, 0.0f)});
    }
  }
  if (s.optimize_meshes && !scene.meshes.empty()) {
    const size_t m = scene.meshes.size();
    p.groups.push_back({ParamKind::MeshColour, s.lr_mesh, std::vector<float>(3 * m, logit_clamped(s.init_albedo))});
    p.groups.push_back({ParamKind::MeshRoughness, s.lr_mesh, std::vector<float>(m, roughness_to_raw(s.init_roughness))});
    if (s.optimize_metallic)
      p.groups.push_back({ParamKind::MeshMetallic, s.lr_mesh, std::vector<float>(m, logit_clamped(s.init_metallic_optimised))});
  }
  return p;
}

namespace {

void check_size(const ParameterGroup& g, size_t n) {
  if (g.raw.size() != n)
    throw Error(std::string("parameter group '") + param_kind_name(g.kind) + "' has " + std::to_string(g.raw.size()) +
                " values, the scene needs " + std::to_string(n));
}

// The environment model's raw numbers: the fine group plus the upsampled coarse one.
std::vector<float> environment_raw(const Parameters& p, const ParameterGroup& fine, const Scene& scene) {
  std::vector<float> raw = fine.raw;
  if (const ParameterGroup* coarse = p.find(ParamKind::EnvironmentCoarse)) coarse_upsampler(*coarse, scene).add_up(coarse->raw.data(), raw.data());
  if (p.env_known.size() == raw.size() && !p.env_known_coarse)  // the seen texels are known
    for (size_t i = 0; i < raw.size(); ++i)
      if (!std::isnan(p.env_known[i])) raw[i] = p.env_known[i];
  return raw;
}

}  // namespace

// The upsampler of a coarse environment group (its width from its size: cw x max(1, cw/2) x 3).
LatlongUpsampler coarse_upsampler(const ParameterGroup& coarse, const Scene& scene) {
  const Environment* env = scene.environment.as<Environment>();
  if (!env) throw Error("a coarse environment level needs the lat-long environment model");
  for (int cw = 1; size_t(cw) * std::max(1, cw / 2) * 3 <= coarse.raw.size(); ++cw)
    if (size_t(cw) * std::max(1, cw / 2) * 3 == coarse.raw.size()) return LatlongUpsampler(cw, std::max(1, cw / 2), env->width(), env->height());
  throw Error("parameter group 'environment_coarse' has " + std::to_string(coarse.raw.size()) + " values, not a w x w/2 RGB grid");
}

void apply_parameters(const Parameters& p, const ParameterSettings& s, Scene& scene) {
  GaussianField& f = *scene.gaussians;
  const size_t n = f.size();
  f.albedo.resize(n);
  f.roughness.resize(n);
  f.metallic.resize(n);
  if (!p.find(ParamKind::GaussianMetallic)) std::fill(f.metallic.begin(), f.metallic.end(), s.init_metallic);
  for (const ParameterGroup& g : p.groups) {
    switch (g.kind) {
      case ParamKind::GaussianAlbedo:
        check_size(g, 3 * n);
        for (size_t i = 0; i < n; ++i) f.albedo[i] = Vec3(sigmoid(g.raw[3 * i]), sigmoid(g.raw[3 * i + 1]), sigmoid(g.raw[3 * i + 2]));
        break;
      case ParamKind::GaussianRoughness:
        check_size(g, n);
        for (size_t i = 0; i < n; ++i) f.roughness[i] = roughness_from_raw(g.raw[i]);
        break;
      case ParamKind::GaussianMetallic:
        check_size(g, n);
        for (size_t i = 0; i < n; ++i) f.metallic[i] = sigmoid(g.raw[i]);
        break;
      case ParamKind::Environment: {
        if (!scene.environment.present()) throw Error("parameters hold an environment, the scene has none");
        check_size(g, scene.environment.parameter_count());
        scene.environment->set_raw(environment_raw(p, g, scene).data());
        break;
      }
      case ParamKind::EnvironmentCoarse: break;  // with Environment
      case ParamKind::MeshColour:
        check_size(g, 3 * scene.meshes.size());
        for (size_t i = 0; i < scene.meshes.size(); ++i)
          scene.meshes[i].material.base_colour = Vec3(sigmoid(g.raw[3 * i]), sigmoid(g.raw[3 * i + 1]), sigmoid(g.raw[3 * i + 2]));
        break;
      case ParamKind::MeshRoughness:
        check_size(g, scene.meshes.size());
        for (size_t i = 0; i < scene.meshes.size(); ++i) scene.meshes[i].material.roughness = roughness_from_raw(g.raw[i]);
        break;
      case ParamKind::MeshMetallic:
        check_size(g, scene.meshes.size());
        for (size_t i = 0; i < scene.meshes.size(); ++i) scene.meshes[i].material.metallic = sigmoid(g.raw[i]);
        break;
      case ParamKind::Exposure:  // not in the scene: the optimiser scales its renders (exposure.h)
        break;
      default: break;  // the geometry stage's kinds (optim/geometry_fit.h)
    }
  }
}

namespace {

// Known (seen) environment texels take no step.
void drop_known(const Parameters& p, std::vector<float>& d) {
  if (p.env_known.size() != d.size()) return;
  for (size_t i = 0; i < d.size(); ++i)
    if (!std::isnan(p.env_known[i])) d[i] = 0.0f;
}

}  // namespace

std::vector<std::vector<float>> raw_gradients(const Parameters& p, const SceneGradients& gr, const Scene& scene) {
  std::vector<std::vector<float>> out;
  out.reserve(p.groups.size());
  auto dsig = [](float x) {
    float s = sigmoid(x);
    return s * (1.0f - s);
  };
  for (const ParameterGroup& g : p.groups) {
    std::vector<float> d(g.raw.size(), 0.0f);
    switch (g.kind) {
      case ParamKind::GaussianAlbedo:
        check_size(g, 3 * gr.gaussian_albedo.size());
        for (size_t i = 0; i < gr.gaussian_albedo.size(); ++i)
          for (int c = 0; c < 3; ++c) d[3 * i + c] = gr.gaussian_albedo[i][c] * dsig(g.raw[3 * i + c]);
        break;
      case ParamKind::GaussianRoughness:
        check_size(g, gr.gaussian_roughness.size());
        for (size_t i = 0; i < d.size(); ++i) d[i] = gr.gaussian_roughness[i] * kRoughnessRange * dsig(g.raw[i]);
        break;
      case ParamKind::GaussianMetallic:
        check_size(g, gr.gaussian_metallic.size());
        for (size_t i = 0; i < d.size(); ++i) d[i] = gr.gaussian_metallic[i] * dsig(g.raw[i]);
        break;
      case ParamKind::Environment:
        check_size(g, gr.environment.size());
        if (!scene.environment.present() || scene.environment.parameter_count() != g.raw.size())
          throw Error("the environment gradients do not match the scene's environment");
        scene.environment->raw_gradient(environment_raw(p, g, scene).data(), gr.environment.data(), d.data());
        drop_known(p, d);
        break;
      case ParamKind::EnvironmentCoarse: {
        // The fine gradient (as above), carried down to the coarse level.
        const ParameterGroup* fine = p.find(ParamKind::Environment);
        if (!fine) throw Error("a coarse environment level without the environment group");
        std::vector<float> d_fine(fine->raw.size());
        scene.environment->raw_gradient(environment_raw(p, *fine, scene).data(), gr.environment.data(), d_fine.data());
        if (!p.env_known_coarse) drop_known(p, d_fine);  // (held fine texels still move the coarse level)
        coarse_upsampler(g, scene).adjoint(d_fine.data(), d.data());
        break;
      }
      case ParamKind::MeshColour:
        check_size(g, 3 * gr.mesh_base_colour.size());
        for (size_t i = 0; i < gr.mesh_base_colour.size(); ++i)
          for (int c = 0; c < 3; ++c) d[3 * i + c] = gr.mesh_base_colour[i][c] * dsig(g.raw[3 * i + c]);
        break;
      case ParamKind::MeshRoughness:
        check_size(g, gr.mesh_roughness.size());
        for (size_t i = 0; i < d.size(); ++i) d[i] = gr.mesh_roughness[i] * kRoughnessRange * dsig(g.raw[i]);
        break;
      case ParamKind::MeshMetallic:
        check_size(g, gr.mesh_metallic.size());
        for (size_t i = 0; i < d.size(); ++i) d[i] = gr.mesh_metallic[i] * dsig(g.raw[i]);
        break;
      case ParamKind::Exposure:  // the optimiser supplies it (ExposureGradients)
        break;
      default: break;  // the geometry stage's kinds (optim/geometry_fit.h)
    }
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace ptir
