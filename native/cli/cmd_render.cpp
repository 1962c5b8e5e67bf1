// `ptir render`: AOV images of a Gaussian field (plus meshes) from a camera.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.h"
#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/render/aov.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/mesh.h"
#include "ptir/transport/orient_normals.h"
#include "progress.h"

namespace ptir::cli {

namespace {

struct RenderOptions {
  std::string gaussians;
  std::vector<std::string> meshes;
  std::string cameras;
  int frame = 0;
  std::string c2w;
  float fov_x = 0.0f;
  int width = 0, height = 0;
  std::string aov = "preview";
  std::string output;
  int spp = 1;
  uint64_t seed = 0;
  std::string interaction = "aggregate";
  float tau_g = 0.5f;
  int k = 16;
  bool quiet = false;
};

std::vector<float> parse_matrix(const std::string& text) {
  std::string s = text;
  for (char& c : s)
    if (c == ',' || c == '[' || c == ']') c = ' ';
  std::istringstream in(s);
  std::vector<float> m;
  float v;
  while (in >> v) m.push_back(v);
  if (m.size() != 16 || !in.eof()) throw Error("--c2w needs 16 numbers (row-major camera-to-world 4x4), got '" + text + "'");
  return m;
}

Camera pick_camera(const RenderOptions& o) {
  if (!o.c2w.empty()) {
    if (o.width <= 0 || o.height <= 0) throw Error("--c2w needs --width and --height");
    if (!(o.fov_x > 0)) throw Error("--c2w needs --fov-x (horizontal field of view, radians)");
    std::vector<float> m = parse_matrix(o.c2w);
    return make_camera(m.data(), o.fov_x, o.width, o.height);
  }
  if (o.cameras.empty()) throw Error("give a camera: --cameras transforms.json [--frame I] or --c2w ... --fov-x ...");
  std::vector<Camera> cams = load_transforms_json(o.cameras, o.width, o.height);
  if (o.frame < 0 || o.frame >= int(cams.size()))
    throw Error(o.cameras, "frame " + std::to_string(o.frame) + " out of range (" + std::to_string(cams.size()) + " frames)");
  return cams[o.frame];
}

int run_render(const RenderOptions& o) {
  auto t0 = std::chrono::steady_clock::now();
  Aov aov = parse_aov(o.aov);
  Camera camera = pick_camera(o);

  GaussianField field;
  if (!o.gaussians.empty()) field = load_gaussians(o.gaussians);
  std::vector<TriangleMesh> meshes;
  for (const auto& m : o.meshes) meshes.push_back(load_mesh(m));
  if (field.size() == 0 && meshes.empty()) throw Error("nothing to render: give --gaussians and/or --mesh");

  AccelSettings accel_settings;
  accel_settings.k = o.k;
  SceneAccel accel(field, meshes, accel_settings);
  // Trainer PLYs carry no normals: face the shortest axes toward the dataset's cameras.
  if (!field.normals_from_file && field.size() > 0) {
    std::vector<Camera> all = o.cameras.empty() ? std::vector<Camera>{camera} : load_transforms_json(o.cameras, camera.width, camera.height);
    // About 256K orientation rays in all, however many cameras the file has.
    int rays_per_camera = std::max(4096, int(262144 / std::max<size_t>(1, all.size())));
    orient_normals_to_cameras(field, accel, all, rays_per_camera);
  }

  AovSettings settings;
  settings.spp = o.spp;
  settings.seed = o.seed;
  settings.interaction.tau_g = o.tau_g;
  if (o.interaction == "discrete") settings.interaction.mode = InteractionMode::Discrete;
  else if (o.interaction != "aggregate") throw Error("--interaction must be 'aggregate' or 'discrete'");

  ProgressBar bar("render " + std::string(aov_name(aov)), o.quiet);
  RenderControl control;
  control.progress = [&](float f) { bar.update(f); };
  TraceStats stats;
  Image image = render_aov(accel, camera, aov, settings, control, &stats);
  bar.finish();
  // 8-bit files get normals as 0.5 + 0.5 n and depth divided by its maximum.
  std::string ext = o.output.size() >= 4 ? o.output.substr(o.output.size() - 4) : "";
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  bool eight_bit = ext != ".exr" && ext != ".hdr" && ext != ".pfm";
  float depth_max = 0.0f;
  write_image(o.output, eight_bit ? aov_for_8bit(aov, image, &depth_max) : image, aov_encoding(aov));
  if (eight_bit && aov == Aov::Depth && !o.quiet) std::fprintf(stderr, "depth PNG: 1.0 = %.4g\n", depth_max);
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!o.quiet)
    std::fprintf(stderr, "wrote %s (%dx%d, %s, %zu Gaussians, %.2f hits/ray, %.2f s)\n", o.output.c_str(), camera.width,
                 camera.height, aov_name(aov), field.size(),
                 double(stats.hits) / std::max(1.0, double(camera.width) * camera.height * o.spp), secs);
  return 0;
}

}  // namespace

Runner add_render_command(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand("render", "Render an image of Gaussians and meshes");
  cmd->add_option("--gaussians", o->gaussians, "3DGS .ply file");
  cmd->add_option("--mesh", o->meshes, "triangle mesh .ply/.obj (repeatable)");
  cmd->add_option("--cameras", o->cameras, "NeRF-synthetic transforms_*.json");
  cmd->add_option("--frame", o->frame, "frame index in --cameras")->capture_default_str();
  cmd->add_option("--c2w", o->c2w, "explicit camera: 16 numbers, row-major camera-to-world (camera looks down -z)");
  cmd->add_option("--fov-x", o->fov_x, "horizontal field of view in radians (with --c2w)");
  cmd->add_option("--width", o->width, "image width (default: from the cameras file or its images)");
  cmd->add_option("--height", o->height, "image height");
  cmd->add_option("--aov", o->aov, "opacity, depth, normal, albedo, roughness, metallic or preview")->capture_default_str();
  cmd->add_option("-o,--output", o->output, "output image (.exr linear float, .png sRGB)")->required();
  cmd->add_option("--spp", o->spp, "samples per pixel (1: pixel centres)")->capture_default_str();
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  cmd->add_option("--interaction", o->interaction, "aggregate or discrete")->capture_default_str();
  cmd->add_option("--tau-g", o->tau_g, "validity threshold on accumulated opacity")->capture_default_str();
  cmd->add_option("--k", o->k, "hits per traversal round (k-buffer size)")->capture_default_str();
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  return [o] { return run_render(*o); };
}

}  // namespace ptir::cli
