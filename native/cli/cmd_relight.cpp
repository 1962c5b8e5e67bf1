// `ptir relight`: the recovered asset under new light -- environment maps,
// near-field point and area lights -- optionally with meshes (walls, floor) that
// cast shadows and bounce light.
//
//   ptir relight --result OUT (--scene scene.json [--camera NAME] | --cameras T.json [--frame I ...])
//       [--env NEW.exr [--env-strength S] [--env-rotation R]]
//       [--point x,y,z,watts[,r,g,b[,radius]] ...] [--area cx,cy,cz,tx,ty,tz,sx,sy,watts[,r,g,b] ...]
//       [--mesh m.ply ... [--mesh-color r,g,b] [--mesh-roughness R]]
//       [--albedo-scale r,g,b|auto] [--width W] [--height H] [--spp N] [--bounces N] [--transparent]
//       [--seed S] [--threads N] -o DIR [-q]
//
// The asset is OUT/gaussians.ply (materials as recovered). With --scene, the
// scene file's meshes, lights, cameras and environment join it (its Gaussians,
// if any, are added too); --env replaces the scene's environment. Lights use
// Blender's units (W). --albedo-scale multiplies the albedo first (auto: the
// scale `ptir eval` found, from OUT/eval/metrics.json). Writes, per camera,
// DIR/<camera>.exr (linear RGBA, A = coverage) and DIR/<camera>.png (sRGB).
// --width/--height re-size the cameras keeping the horizontal field of view
// (and the aspect ratio when only one is given).
// --transparent: the environment seen directly is left out (premultiplied RGB,
// A = coverage, like Cycles' transparent film); it still lights the scene.
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "brdf_option.h"
#include "commands.h"
#include "image_budget.h"
#include "output_guard.h"
#include "filter_flags.h"
#include "progress.h"
#include "ptir/core/error.h"
#include "ptir/eval/relight.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/mesh.h"
#include "ptir/scene/scene.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/orient_normals.h"
#include "ptir/transport/path_tracer.h"

namespace fs = std::filesystem;

namespace ptir::cli {

namespace {

struct RelightOptions {
  std::string result, scene, camera, cameras, env, output;
  std::string brdf;  // --brdf (empty: the scene file's, else the --cameras file's "ptir_brdf", else principled-v2)
  std::vector<int> frames;
  int width = 0, height = 0;
  float env_strength = 1.0f, env_rotation = 0.0f;
  std::vector<std::string> points, areas, meshes;
  std::string mesh_color = "0.8,0.8,0.8";
  float mesh_roughness = 0.5f;
  std::string albedo_scale;
  int spp = 128, bounces = 4;
  bool transparent = false;
  uint64_t seed = 0;
  int threads = 0;
  FilterFlags filter;
  bool quiet = false;
  bool force = false;
  double max_memory_gib = 0;
};

std::array<double, 3> parse_triple(const std::string& text, const char* what) {
  std::string t = text;
  for (char& c : t)
    if (c == ',') c = ' ';
  std::istringstream in(t);
  std::array<double, 3> v{};
  if (!(in >> v[0] >> v[1] >> v[2]) || !(in >> std::ws).eof())
    throw Error(std::string(what) + " must be three numbers r,g,b, got '" + text + "'");
  for (double x : v)
    if (!std::isfinite(x) || x < 0) throw Error(std::string(what) + " must be finite and >= 0, got '" + text + "'");
  return v;
}

std::array<double, 3> albedo_scale_of(const RelightOptions& o) {
  if (o.albedo_scale.empty()) return {1.0, 1.0, 1.0};
  if (o.albedo_scale != "auto") return parse_triple(o.albedo_scale, "--albedo-scale");
  fs::path m = fs::path(o.result) / "eval" / "metrics.json";
  std::ifstream f(m);
  if (!f) throw Error(m.string(), "--albedo-scale auto: no metrics (run `ptir eval` first)");
  nlohmann::json j;
  try {
    f >> j;
  } catch (const std::exception& e) {
    throw Error(m.string(), std::string("bad JSON: ") + e.what());
  }
  if (!j.contains("albedo_scale") || !j["albedo_scale"].is_array() || j["albedo_scale"].size() != 3)
    throw Error(m.string(), "--albedo-scale auto: no albedo_scale (the dataset had no albedo ground truth)");
  return {j["albedo_scale"][0].get<double>(), j["albedo_scale"][1].get<double>(), j["albedo_scale"][2].get<double>()};
}

std::string safe_name(const std::string& name, size_t i) {
  std::string s;
  for (char c : name) s += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.') ? c : '_';
  if (s.empty() || s == "." || s == "..") {
    char b[32];
    std::snprintf(b, sizeof b, "frame_%03zu", i);
    return b;
  }
  return s;
}

// The scene (from --scene, or empty with --cameras) and the cameras to render
// (resized by --width/--height); *all_cameras gets every camera, for orienting normals.
Scene relight_scene_and_cameras(const RelightOptions& o, std::vector<Camera>* cameras, std::vector<Camera>* all_cameras) {
  Scene scene;
  if (!o.scene.empty()) {
    scene = load_scene_json(o.scene);
    if (!o.camera.empty()) cameras->push_back(scene.camera(o.camera));
    else *cameras = scene.cameras;
    if (cameras->empty()) throw Error(o.scene, "the scene has no camera (add one, or use --cameras)");
    *all_cameras = scene.cameras;
  } else {
    *cameras = load_transforms_json(o.cameras);
    *all_cameras = *cameras;
    if (!o.frames.empty()) {
      std::vector<Camera> picked;
      for (int f : o.frames) {
        if (f < 0 || f >= int(cameras->size()))
          throw Error(o.cameras, "frame " + std::to_string(f) + " out of range (" + std::to_string(cameras->size()) + " frames)");
        picked.push_back((*cameras)[size_t(f)]);
      }
      *cameras = picked;
    }
    scene.cameras = *cameras;
    scene.source_path = "command line";
  }
  if (o.width < 0 || o.height < 0) throw Error("--width/--height must be positive");
  if (o.width > 0 || o.height > 0)
    for (Camera& c : *cameras) {
      // Resize keeping the horizontal field of view (and the aspect ratio when only one is given).
      int w = o.width > 0 ? o.width : int(std::lround(double(o.height) * c.width / c.height));
      int h = o.height > 0 ? o.height : int(std::lround(double(o.width) * c.height / c.width));
      w = std::max(1, w);
      h = std::max(1, h);
      check_image_budget(w, h, o.max_memory_gib, "camera '" + c.name + "'");  // before the size's own checks
      c = c.resized(w, h);  // the intrinsics scale with it (a capture's principal point too)
    }
  for (const Camera& c : *cameras) check_image_budget(c.width, c.height, o.max_memory_gib, "camera '" + c.name + "'");
  return scene;
}

// Adds the recovered asset (albedo scaled), the environment, lights and meshes of the options.
void add_relight_content(const RelightOptions& o, const CLI::App& cmd, const fs::path& ply,
                         const std::array<double, 3>& scale, Scene& scene) {
  GaussianField asset = load_gaussians(ply.string());
  eval::scale_albedo(asset, scale);
  if (scene.gaussians->size() == 0) *scene.gaussians = std::move(asset);
  else append_gaussians(*scene.gaussians, std::move(asset));
  if (!o.env.empty()) scene.environment = Environment::load(o.env, o.env_strength, o.env_rotation);
  for (const std::string& p : o.points) scene.emitters.emplace_back(eval::parse_point_light(p));
  for (const std::string& a : o.areas) scene.emitters.emplace_back(eval::parse_area_light(a));
  if (!o.meshes.empty()) {
    std::array<double, 3> c = parse_triple(o.mesh_color, "--mesh-color");
    if (!(o.mesh_roughness >= 0.0f && o.mesh_roughness <= 1.0f)) throw Error("--mesh-roughness must be in [0, 1]");
    for (const std::string& m : o.meshes) {
      TriangleMesh mesh = load_mesh(m);
      mesh.material.base_colour = Vec3(float(c[0]), float(c[1]), float(c[2]));
      mesh.material.roughness = o.mesh_roughness;
      mesh.material.name = fs::path(m).stem().string();
      scene.meshes.push_back(std::move(mesh));
    }
  } else if (cmd.count("--mesh-color") || cmd.count("--mesh-roughness")) {
    throw Error("--mesh-color/--mesh-roughness need --mesh");
  }
  if (!scene.environment.present() && scene.emitters.empty())
    throw Error("no light: give --env, --point or --area (or a scene file with lights or an environment)");
}

// Renders one camera and writes OUT/<name>.exr (associated RGBA) and .png (straight;
// docs/alpha.md). Without --transparent the environment is seen behind the object and
// the picture is opaque (A = 1) when there is one.
void render_relit_view(const RelightOptions& o, const PathTracer& tracer, const IntegratorSettings& is, const Camera& cam,
                       const std::string& name) {
  ProgressBar bar("relight " + name, o.quiet);
  RenderControl control;
  control.progress = [&](float f) { bar.update(f); };
  Image img = o.transparent ? eval::render_transparent(tracer, cam, is, control) : render_path(tracer, cam, is, control);
  bar.finish();
  set_film_alpha(img, o.transparent, tracer.scene().environment.present());
  const fs::path exr = fs::path(o.output) / (name + ".exr"), png = fs::path(o.output) / (name + ".png");
  write_image(exr.string(), img, Encoding::Colour);
  write_image(png.string(), img, Encoding::Colour);  // un-premultiplied by write_image
}

int run_relight(const RelightOptions& o, const CLI::App& cmd) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  if (o.spp < 1) throw Error("--spp must be at least 1");
  if (o.bounces < 0) throw Error("--bounces must be at least 0");
  if (o.scene.empty() == o.cameras.empty()) throw Error("give exactly one of --scene scene.json and --cameras transforms.json");
  if (!o.scene.empty() && cmd.count("--frame")) throw Error("--frame goes with --cameras; with --scene use --camera NAME");
  if (o.scene.empty() && cmd.count("--camera")) throw Error("--camera goes with --scene; with --cameras use --frame I");
  if (o.env.empty() && (cmd.count("--env-strength") || cmd.count("--env-rotation")))
    throw Error("--env-strength/--env-rotation need --env");

  const fs::path ply = fs::path(o.result) / "gaussians.ply";
  if (!fs::exists(ply)) throw Error(ply.string(), "no such file (the result folder of `ptir optimize`)");
  Inputs in{{ply.string(), o.cameras, o.env}, {o.result}, {o.scene}, {}};
  in.files.insert(in.files.end(), o.meshes.begin(), o.meshes.end());
  guard_outputs(in, {{}, {o.output}}, o.force);
  const auto lock = lock_output_folder(o.output, "ptir relight");
  remove_stale_outputs({o.output}, o.quiet);
  const std::array<double, 3> scale = albedo_scale_of(o);

  std::vector<Camera> cameras, all_cameras;
  Scene scene = relight_scene_and_cameras(o, &cameras, &all_cameras);
  add_relight_content(o, cmd, ply, scale, scene);

  PathTracer tracer(scene);
  // Gaussians without normals from their files (a trainer's PLY, or scene-file Gaussians) face
  // the cameras that see them, as `ptir render` does.
  if (!scene.gaussians->normals_from_file) orient_normals_to_cameras(*scene.gaussians, tracer.accel(), all_cameras);
  IntegratorSettings is = scene.integrator;
  if (o.scene.empty() || cmd.count("--spp")) is.spp = o.spp;
  if (o.scene.empty() || cmd.count("--bounces")) is.max_bounces = o.bounces;
  if (cmd.count("--seed")) is.seed = o.seed;
  // The model: --brdf, else the scene file's, else what the --cameras file records, else principled-v2.
  is.brdf = resolve_bsdf_model(scene.brdf_from_file, is.brdf,
                               o.cameras.empty() ? std::nullopt : read_recorded_bsdf_model(o.cameras));
  cli::apply_brdf_option(o.brdf, is.brdf);
  apply_filter_flags(o.filter, cmd, is.filter);

  fs::create_directories(o.output);
  for (size_t i = 0; i < cameras.size(); ++i) render_relit_view(o, tracer, is, cameras[i], safe_name(cameras[i].name, i));
  if (!o.quiet)
    std::fprintf(stderr,
                 "wrote %zu relit view(s) to %s (%dx%d, %d spp, %d bounces, %zu Gaussians, %zu meshes, %zu lights%s; "
                 "albedo scale %.3f %.3f %.3f; %.1f s)\n",
                 cameras.size(), o.output.c_str(), cameras[0].width, cameras[0].height, is.spp, is.max_bounces,
                 scene.gaussians->size(), scene.meshes.size(), scene.emitters.size(),
                 scene.environment.present() ? " + environment" : "", scale[0], scale[1], scale[2],
                 std::chrono::duration<double>(Clock::now() - t0).count());
  return 0;
}

}  // namespace

Runner add_relight_command(CLI::App& app) {
  auto o = std::make_shared<RelightOptions>();
  CLI::App* cmd = app.add_subcommand("relight", "Render the recovered asset under new environments and near-field lights");
  cmd->add_option("--result", o->result, "result folder of `ptir optimize` (gaussians.ply)")->required();
  cmd->add_option("--scene", o->scene, "scene file: meshes, lights, cameras, environment (docs/scene_format.md)");
  cmd->add_option("--camera", o->camera, "with --scene: render only this camera");
  cmd->add_option("--cameras", o->cameras, "NeRF-synthetic transforms_*.json: its cameras");
  cmd->add_option("--frame", o->frames, "with --cameras: render only this frame index (repeatable)");
  cmd->add_option("--width", o->width, "re-size the cameras to this width (keeps the horizontal field of view)");
  cmd->add_option("--height", o->height, "re-size the cameras to this height");
  cmd->add_option("--env", o->env, "lat-long environment map (.exr/.hdr, Blender orientation)");
  cmd->add_option("--env-strength", o->env_strength, "environment strength (Background node Strength)");
  cmd->add_option("--env-rotation", o->env_rotation, "environment Z rotation in radians (Mapping node)");
  cmd->add_option("--point", o->points, "point light x,y,z,watts[,r,g,b[,radius]] (repeatable; Blender units)");
  cmd->add_option("--area", o->areas,
                  "rectangular area light cx,cy,cz,tx,ty,tz,size_x,size_y,watts[,r,g,b] centred at c facing the point t "
                  "(repeatable)");
  cmd->add_option("--mesh", o->meshes, "triangle mesh .ply/.obj (walls, floor; repeatable): casts shadows, bounces light");
  cmd->add_option("--mesh-color", o->mesh_color, "linear base colour r,g,b of the --mesh meshes")->capture_default_str();
  cmd->add_option("--mesh-roughness", o->mesh_roughness, "roughness of the --mesh meshes")->capture_default_str();
  cmd->add_option("--albedo-scale", o->albedo_scale, "multiply the albedo by r,g,b first; 'auto': the scale in OUT/eval/metrics.json");
  cmd->add_option("--spp", o->spp, "samples per pixel")->capture_default_str();
  cmd->add_option("--bounces", o->bounces, "indirect bounces")->capture_default_str();
  cmd->add_flag("--transparent", o->transparent, "leave the directly seen environment out (alpha = coverage)");
  cmd->add_option("--seed", o->seed, "random seed");
  cli::add_brdf_option(cmd, &o->brdf);
  add_filter_flags(cmd, &o->filter);
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all)");
  cmd->add_option("-o,--output", o->output, "output folder")->required();
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  add_force_flag(cmd, o->force);
  add_max_memory_flag(cmd, o->max_memory_gib);
  return [o, cmd] { return run_relight(*o, *cmd); };
}

}  // namespace ptir::cli
