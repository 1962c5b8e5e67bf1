// `ptir render`: path-traced colour or AOV images.
//
//   ptir render scene.json -o out.exr [--spp N] [--bounces N] [--camera NAME] [--seed S] [--threads N] [--transparent]
//       the scene file (docs/scene_format.md); path-traced colour by default.
//   ptir render --gaussians g.ply [--mesh m.ply ...] (--cameras t.json [--frame I] | --c2w ... --fov-x F)
//       [--aov preview|opacity|depth|normal|albedo|diffuse_color|roughness|metallic|rgb] [--env map.exr ...] -o out.png
//       the flag form: AOVs of the primary hit, or (--aov rgb) path-traced colour under --env.
//
// Alpha (docs/alpha.md): an EXR holds associated RGBA (RGB premultiplied by A),
// a PNG straight RGBA. Path-traced colour: A is the coverage when nothing is seen
// behind the objects (--transparent, Cycles' Film > Transparent, or a scene
// without an environment), else 1 (render/render_path.h set_film_alpha); the
// preview AOV is associated like it; data AOVs hold the surface's values with
// the coverage as A.
//
// Integrator switches (both forms; in the scene form they override the file):
// --spp, --bounces, --seed, --interaction aggregate|discrete, --tau-g,
// --no-geometric-criterion, --self-intersection backface|fixed. --threads N limits
// TBB: the image does not depend on it (random numbers are keyed per pixel/sample).
// -o is .exr or .png; an output (or --stats-json) that is an input file is refused
// unless --force (pipeline/output_guard.h); sizes past --max-memory are refused before
// anything is allocated (cli/image_budget.h).
//
// Under MPI (`mpirun -np N ptir render ...`, native/mpi/world.h) the image is dealt
// to the ranks in row bands (render/row_bands.h) and gathered into the one file
// rank 0 writes: AOVs are bit-identical to a one-process render, path-traced
// colour equal to float rounding (row_bands.h says why).
#include <tbb/global_control.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "brdf_option.h"
#include "commands.h"
#include "filter_flags.h"
#include "image_budget.h"
#include "output_guard.h"
#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/render/aov.h"
#include "ptir/render/render_path.h"
#include "ptir/render/row_bands.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/mesh.h"
#include "ptir/scene/scene.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/orient_normals.h"
#include "ptir/transport/path_tracer.h"
#include "progress.h"
#include "world.h"

namespace ptir::cli {

namespace {

struct RenderOptions {
  std::string scene;  // positional scene file
  std::string brdf;   // --brdf (empty: the scene's)
  std::string camera_name;
  std::string gaussians;
  std::vector<std::string> meshes;
  std::string cameras;
  int frame = 0;
  std::string c2w;
  float fov_x = 0.0f;
  int width = 0, height = 0;
  std::string aov;  // default: "rgb" with a scene file, "preview" in the flag form
  std::string output;
  int spp = 1;
  int bounces = 2;
  uint64_t seed = 0;
  std::string interaction = "aggregate";
  float tau_g = 0.5f;
  bool no_geometric_criterion = false;
  bool transparent = false;  // leave the directly seen environment out (Film > Transparent)
  std::string self_intersection = "backface";
  std::string env;
  float env_strength = 1.0f;
  float env_rotation = 0.0f;
  int k = 32;
  int threads = 0;
  FilterFlags filter;
  std::string stats_json;
  bool quiet = false;
  bool force = false;
  double max_memory_gib = 0;  // 0: half the machine's memory
};

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

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

Camera pick_flag_camera(const RenderOptions& o) {
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

// A scene camera by name, or by index when no camera has that name.
const Camera& pick_scene_camera(const Scene& scene, const std::string& name) {
  if (!name.empty() && !scene.cameras.empty() &&
      std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isdigit(c); })) {
    bool named = std::any_of(scene.cameras.begin(), scene.cameras.end(), [&](const Camera& c) { return c.name == name; });
    if (!named) {
      size_t i = std::stoul(name);
      if (i >= scene.cameras.size())
        throw Error(scene.source_path, "camera index " + name + " out of range (" + std::to_string(scene.cameras.size()) +
                                           " cameras)");
      return scene.cameras[i];
    }
  }
  return scene.camera(name);
}

// Command-line switches override the settings (the scene file's, or the defaults).
void apply_integrator_flags(const RenderOptions& o, const CLI::App& cmd, IntegratorSettings& s) {
  if (cmd.count("--spp")) s.spp = o.spp;
  if (cmd.count("--bounces")) s.max_bounces = o.bounces;
  if (cmd.count("--seed")) s.seed = o.seed;
  cli::apply_brdf_option(o.brdf, s.brdf);
  if (cmd.count("--interaction")) s.interaction.mode = parse_interaction_mode(o.interaction, "--interaction");
  if (cmd.count("--tau-g")) s.interaction.tau_g = o.tau_g;
  if (o.no_geometric_criterion) s.geometric_criterion = false;
  if (cmd.count("--self-intersection"))
    s.self_intersection = parse_self_intersection(o.self_intersection, "--self-intersection");
  apply_filter_flags(o.filter, cmd, s.filter);
  if (s.spp < 1) throw Error("--spp must be at least 1");
  if (s.max_bounces < 0) throw Error("--bounces must be at least 0");
}

std::string lower_ext(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

size_t triangle_count(const Scene& s) {
  size_t n = 0;
  for (const TriangleMesh& m : s.meshes) n += m.triangles.size();
  return n;
}

// Before anything is loaded: the output must be .exr or .png (decision: the two
// formats the help promises; OIIO would write any other by its extension), must
// not replace an input, and temps a killed run left beside it go.
void check_render_outputs(const RenderOptions& o) {
  const std::string ext = lower_ext(o.output);
  if (ext != ".exr" && ext != ".png")
    throw Error(o.output, "output must be .exr (linear float) or .png (sRGB), not '" + (ext.empty() ? "no extension" : ext) + "'");
  Inputs in;
  in.files = {o.gaussians, o.cameras, o.env};
  in.files.insert(in.files.end(), o.meshes.begin(), o.meshes.end());
  in.scenes = {o.scene};
  guard_outputs(in, Outputs{{o.output, o.stats_json}, {}}, o.force);
  std::vector<std::string> folders;
  for (const std::string& file : {o.output, o.stats_json}) {
    const std::filesystem::path p(file);
    if (!file.empty()) folders.push_back(p.has_parent_path() ? p.parent_path().string() : ".");
  }
  remove_stale_outputs(folders, o.quiet);
}

// Scene form: the file's scene and camera, re-sized by --width/--height keeping
// the horizontal field of view (and the aspect ratio when only one is given).
void load_scene_form(const RenderOptions& o, const CLI::App& cmd, Scene& scene, Camera& camera) {
  for (const char* flag : {"--gaussians", "--mesh", "--cameras", "--frame", "--c2w", "--fov-x", "--env", "--env-strength",
                           "--env-rotation"})
    if (cmd.count(flag))
      throw Error(std::string(flag) + " belongs to the flag form; with a scene file, put it in the file (" + o.scene + ")");
  if (o.width < 0 || o.height < 0) throw Error("--width/--height must be positive");
  scene = load_scene_json(o.scene);
  orient_scene_normals(scene);
  camera = pick_scene_camera(scene, o.camera_name);
  if (o.width > 0 || o.height > 0) {
    const int64_t w = o.width > 0 ? o.width : std::llround(double(o.height) * camera.width / camera.height);
    const int64_t h = o.height > 0 ? o.height : std::llround(double(o.width) * camera.height / camera.width);
    check_image_budget(w, h, o.max_memory_gib, "--width/--height");
    camera = camera.resized(int(std::max<int64_t>(1, w)), int(std::max<int64_t>(1, h)));
  }
}

// Flag form: the Gaussians, meshes and environment given as flags, one camera.
void load_flag_form(const RenderOptions& o, const CLI::App& cmd, Scene& scene, Camera& camera) {
  if (cmd.count("--camera")) throw Error("--camera picks a camera of a scene file; in the flag form use --cameras/--frame or --c2w");
  check_image_budget(o.width, o.height, o.max_memory_gib, "--width/--height");
  camera = pick_flag_camera(o);
  if (!o.gaussians.empty()) *scene.gaussians = load_gaussians(o.gaussians);
  for (const auto& m : o.meshes) scene.meshes.push_back(load_mesh(m));
  if (scene.gaussians->size() == 0 && scene.meshes.empty()) throw Error("nothing to render: give --gaussians and/or --mesh");
  if (!o.env.empty()) scene.environment = Environment::load(o.env, o.env_strength, o.env_rotation);
  else if (cmd.count("--env-strength") || cmd.count("--env-rotation")) throw Error("--env-strength/--env-rotation need --env");
  scene.cameras.push_back(camera);
  scene.source_path = "command line";
}

// Flag form: trainer PLYs carry no normals, so face the shortest axes toward the
// dataset's cameras (the scene form did this while loading).
void orient_flag_normals(const RenderOptions& o, const Camera& camera, PathTracer& tracer, GaussianField& field) {
  if (field.normals_from_file || field.size() == 0) return;
  std::vector<Camera> all =
      o.cameras.empty() ? std::vector<Camera>{camera} : load_transforms_json(o.cameras, camera.width, camera.height);
  int rays_per_camera = std::max(4096, int(262144 / std::max<size_t>(1, all.size())));
  orient_normals_to_cameras(field, tracer.accel(), all, rays_per_camera);
}

// 8-bit files get sRGB colour; AOV data is mapped (normals 0.5 + 0.5 n, depth / max).
void write_render(const RenderOptions& o, const std::optional<Aov>& aov, const Image& image) {
  const bool eight_bit = lower_ext(o.output) == ".png";
  if (!aov && eight_bit && !o.transparent) {
    // The environment is part of a path-traced picture: 8-bit files get RGB only (an
    // alpha channel would make the sky transparent, and PNG alpha is unassociated).
    Image rgb_only(image.width, image.height, {"R", "G", "B"});
    for (size_t i = 0, n = size_t(image.width) * image.height; i < n; ++i)
      for (int c = 0; c < 3; ++c) rgb_only.pixels[i * 3 + c] = image.pixels[i * 4 + c];
    write_image(o.output, rgb_only, Encoding::Colour);
  } else if (!aov) {
    write_image(o.output, image, Encoding::Colour);  // EXR: associated; PNG (--transparent): straight
  } else {
    float depth_max = 0.0f;
    write_image(o.output, eight_bit ? aov_for_8bit(*aov, image, &depth_max) : image, aov_encoding(*aov));
    if (eight_bit && *aov == Aov::Depth && !o.quiet) std::fprintf(stderr, "depth PNG: 1.0 = %.4g\n", depth_max);
  }
}

struct RenderReport {
  std::string aov_text;
  double load_s = 0, build_s = 0, render_s = 0, total_s = 0;
  PathStats path;
  TraceStats trace;
};

// The summary line on stderr and the --stats-json file (written atomically).
void report_render(const RenderOptions& o, const Scene& scene, const Camera& camera, const IntegratorSettings& settings,
                   const std::optional<Aov>& aov, const RenderReport& r) {
  const double samples = double(camera.width) * camera.height * settings.spp;
  const size_t gaussians = scene.gaussians->size();
  if (!o.quiet) {
    if (!aov)
      std::fprintf(stderr,
                   "wrote %s (%dx%d, rgb, %d spp, %d bounces, %zu Gaussians, %zu triangles, %zu lights; render %.2f s, "
                   "%.3g path samples/s, %.2f vertices/path; total %.2f s)\n",
                   o.output.c_str(), camera.width, camera.height, settings.spp, settings.max_bounces, gaussians,
                   triangle_count(scene), scene.emitters.size(), r.render_s, samples / std::max(r.render_s, 1e-9),
                   double(r.path.vertices) / std::max(1.0, double(r.path.paths)), r.total_s);
    else
      std::fprintf(stderr, "wrote %s (%dx%d, %s, %zu Gaussians, %.2f hits/ray, %.2f s)\n", o.output.c_str(), camera.width,
                   camera.height, aov_name(*aov), gaussians, double(r.trace.hits) / std::max(1.0, samples), r.total_s);
  }
  if (o.stats_json.empty()) return;
  const nlohmann::ordered_json js = {
      {"width", camera.width}, {"height", camera.height}, {"spp", settings.spp}, {"bounces", settings.max_bounces},
      {"aov", r.aov_text}, {"gaussians", gaussians}, {"triangles", triangle_count(scene)},
      {"lights", scene.emitters.size()}, {"threads", o.threads}, {"load_s", r.load_s}, {"build_s", r.build_s},
      {"render_s", r.render_s}, {"total_s", r.total_s}, {"path_samples", samples}, {"paths", r.path.paths},
      {"vertices", r.path.vertices}, {"shadow_rays", r.path.shadow_rays}};
  io::write_text_atomic(o.stats_json, js.dump() + "\n");
}

// Data-parallel runs: the counters of every rank's bands (the times stay rank 0's).
void sum_over_ranks(const Communicator& comm, RenderReport& r) {
  if (comm.size() == 1) return;
  double c[] = {double(r.path.paths), double(r.path.vertices), double(r.path.shadow_rays), double(r.trace.hits)};
  comm.allreduce_sum(c, 4);
  r.path = {uint64_t(c[0]), uint64_t(c[1]), uint64_t(c[2])};
  r.trace.hits = uint64_t(c[3]);
}

int run_render(const RenderOptions& o, const CLI::App& cmd) {
  const auto t0 = Clock::now();
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  check_render_outputs(o);

  const bool scene_mode = !o.scene.empty();
  RenderReport report;
  report.aov_text = o.aov.empty() ? (scene_mode ? "rgb" : "preview") : o.aov;
  std::optional<Aov> aov;
  if (report.aov_text != "rgb") aov = parse_aov(report.aov_text);  // throws listing the names

  Scene scene;
  Camera camera;
  if (scene_mode) load_scene_form(o, cmd, scene, camera);
  else load_flag_form(o, cmd, scene, camera);
  check_image_budget(camera.width, camera.height, o.max_memory_gib, scene_mode ? o.scene : "camera");
  if (aov && (cmd.count("--bounces") || o.no_geometric_criterion || cmd.count("--self-intersection") || o.transparent))
    throw Error("--bounces, --no-geometric-criterion, --self-intersection and --transparent apply to --aov rgb (path tracing) only");
  IntegratorSettings settings = scene.integrator;
  apply_integrator_flags(o, cmd, settings);
  if (aov && !cmd.count("--spp")) settings.spp = 1;  // AOVs: pixel centres unless asked
  report.load_s = seconds_since(t0);

  const auto t1 = Clock::now();
  AccelSettings accel_settings;
  accel_settings.k = o.k;
  PathTracer tracer(scene, accel_settings);
  if (!scene_mode) orient_flag_normals(o, camera, tracer, *scene.gaussians);
  report.build_s = seconds_since(t1);

  // Data-parallel runs: this rank's row bands, gathered; rank 0 reports and writes.
  const Communicator& comm = world();
  const size_t bands = rank_row_bands(camera.height, comm).size();
  ProgressBar bar("render " + report.aov_text, o.quiet || comm.rank() != 0);
  RenderControl control;
  size_t band_now = 0;
  control.progress = [&](float f) { bar.update((float(band_now) + f) / float(std::max<size_t>(bands, 1))); };
  const auto t2 = Clock::now();
  AovSettings as;
  as.spp = settings.spp;
  as.seed = settings.seed;
  as.filter = settings.filter;
  as.interaction = settings.interaction;
  Image image = render_row_bands(comm, camera, [&](const Camera& band, size_t b) {
    band_now = b;
    if (!aov) return render_path(tracer, band, settings, control, &report.path, nullptr, o.transparent);
    return render_aov(tracer.accel(), band, *aov, as, control, &report.trace);
  });
  report.render_s = seconds_since(t2);
  bar.finish();
  sum_over_ranks(comm, report);
  if (comm.rank() != 0) return 0;
  if (!aov) set_film_alpha(image, o.transparent, scene.environment.present());
  write_render(o, aov, image);
  report.total_s = seconds_since(t0);
  report_render(o, scene, camera, settings, aov, report);
  return 0;
}

}  // namespace

Runner add_render_command(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand("render", "Render an image: path-traced colour or AOVs, from a scene file or flags");
  cmd->add_option("scene", o->scene, "scene file (.json, see docs/scene_format.md); path-traced colour by default");
  cmd->add_option("--camera", o->camera_name, "scene form: camera name (or index); default: the first");
  cmd->add_option("--gaussians", o->gaussians, "3DGS .ply file");
  cmd->add_option("--mesh", o->meshes, "triangle mesh .ply/.obj (repeatable)");
  cmd->add_option("--cameras", o->cameras, "NeRF-synthetic transforms_*.json");
  cmd->add_option("--frame", o->frame, "frame index in --cameras")->capture_default_str();
  cmd->add_option("--c2w", o->c2w, "explicit camera: 16 numbers, row-major camera-to-world (camera looks down -z)");
  cmd->add_option("--fov-x", o->fov_x, "horizontal field of view in radians (with --c2w)");
  cmd->add_option("--width", o->width, "image width (flag form: default from the cameras file; scene form: resize)");
  cmd->add_option("--height", o->height, "image height");
  cmd->add_option("--aov", o->aov,
                  "rgb (path-traced colour), opacity, depth, normal, albedo (base colour), diffuse_color (Blender's Diffuse Color "
                  "pass: base colour x (1 - metallic)), roughness, metallic or preview "
                  "(default: rgb with a scene file, preview otherwise)");
  cmd->add_option("-o,--output", o->output, "output image: .exr (linear float) or .png (sRGB)")->required();
  cmd->add_option("--spp", o->spp, "samples per pixel (default: the scene's, 32; AOVs: 1 = pixel centres)");
  cmd->add_option("--bounces", o->bounces, "indirect bounces (0: direct light only; default: the scene's, 2)");
  cmd->add_option("--seed", o->seed, "random seed (same seed, same image, on any thread count)");
  add_filter_flags(cmd, &o->filter);
  cmd->add_option("--interaction", o->interaction, "Gaussian interaction: aggregate or discrete");
  cli::add_brdf_option(cmd, &o->brdf);
  cmd->add_option("--tau-g", o->tau_g, "validity threshold on accumulated opacity");
  cmd->add_flag("--no-geometric-criterion", o->no_geometric_criterion,
                "ablation: every Gaussian hit with O > 0 is an interaction (no chi_geom gate)");
  cmd->add_option("--self-intersection", o->self_intersection,
                  "backface (backface-aware rejection) or fixed (PTIR code's fixed offset)");
  cmd->add_flag("--transparent", o->transparent,
                "leave the directly seen environment out (Cycles' Film > Transparent): RGB premultiplied by A = coverage");
  cmd->add_option("--env", o->env, "flag form: lat-long environment map (.exr/.hdr, Blender orientation)");
  cmd->add_option("--env-strength", o->env_strength, "environment strength (Background node Strength)");
  cmd->add_option("--env-rotation", o->env_rotation, "environment Z rotation in radians (Mapping node)");
  cmd->add_option("--k", o->k, "hits per traversal round (k-buffer size)")->capture_default_str();
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all)");
  cmd->add_option("--stats-json", o->stats_json, "write timings and counts to this JSON file");
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  add_force_flag(cmd, o->force);
  add_max_memory_flag(cmd, o->max_memory_gib);
  return [o, cmd] { return run_render(*o, *cmd); };
}

}  // namespace ptir::cli
