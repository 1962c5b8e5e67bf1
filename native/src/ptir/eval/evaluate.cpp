#include "ptir/eval/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/eval/capture_result.h"
#include "ptir/eval/contact_sheet.h"
#include "ptir/eval/env_score.h"
#include "ptir/eval/metrics.h"
#include "ptir/eval/tensoir_albedo.h"
#include "ptir/eval/relight.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/atomic_folder.h"
#include "ptir/scene/dataset.h"
#include "ptir/render/aov.h"
#include "ptir/render/row_bands.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/orient_normals.h"
#include "ptir/transport/path_tracer.h"

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace ptir::eval {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

constexpr double kPsnrCap = 100.0;  // identical images (mse 0) report this instead of +inf (JSON has no inf)
constexpr float kColourErrorScale = 0.25f;   // display-value difference shown as full scale
constexpr float kRoughnessErrorScale = 0.5f;
constexpr float kNormalErrorScale = 45.0f;   // degrees

double capped(double psnr) { return std::isfinite(psnr) ? std::min(psnr, kPsnrCap) : kPsnrCap; }

// The mean of the values, or null when there are none.
json mean_or_null(const std::vector<double>& v) {
  if (v.empty()) return nullptr;
  double s = 0.0;
  for (double x : v) s += x;
  return s / double(v.size());
}

std::string view_folder(size_t i) {
  char b[32];
  std::snprintf(b, sizeof b, "test_%03zu", i);
  return b;
}

// Filesystem queries and folder creation at evaluate's edges: failures become
// ptir::Error naming the path instead of std::filesystem_error.
bool file_exists(const fs::path& p) {
  std::error_code ec;
  bool e = fs::exists(p, ec);
  if (ec) throw Error(p.string(), "cannot be checked: " + ec.message());
  return e;
}

void make_folder(const fs::path& p) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec || !fs::is_directory(p, ec)) throw Error(p.string(), "cannot create the folder" + (ec ? ": " + ec.message() : ""));
}

std::string absolute_path(const std::string& p) {
  std::error_code ec;
  fs::path a = fs::absolute(p, ec);
  if (ec) throw Error(p, "cannot resolve the path: " + ec.message());
  return a.string();
}

// 1-channel image: 1 where a > 0.5 or b > 0.5 (the pixels an error map shows).
Image union_mask(const Image& a, const Image& b) {
  Image out(a.width, a.height, {"Y"});
  for (size_t i = 0, n = size_t(a.width) * a.height; i < n; ++i)
    out.pixels[i] = (a.pixels[i * a.channels] > 0.5f || b.pixels[i * b.channels + (b.channels - 1)] > 0.5f) ? 1.0f : 0.0f;
  return out;
}

// Relit ground truth next to a view's image: <folder>/rgba_<name>.png for the
// TensoIR layout, else <folder>/<stem>_<name>.png; "" when absent.
std::string relight_gt_path(const std::string& image, const std::string& name) {
  fs::path p(image);
  for (const char* ext : {".png", ".exr"}) {
    fs::path a = p.parent_path() / ("rgba_" + name + ext);
    if (file_exists(a)) return a.string();
    fs::path b = p.parent_path() / (p.stem().string() + "_" + name + ext);
    if (file_exists(b)) return b.string();
  }
  return "";
}

std::string fmt(const json& v, const char* f) {
  if (v.is_null()) return "n/a";
  char b[64];
  std::snprintf(b, sizeof b, f, v.get<double>());
  return b;
}

// A PSNR at the cap (kPsnrCap: the images are identical, e.g. the oracle's true environment) reads "exact".
std::string fmt_db(const json& v) {
  return v.is_number() && v.get<double>() >= kPsnrCap ? std::string("exact") : fmt(v, "%.2f");
}

}  // namespace

RelightEnv parse_relight(const std::string& spec) {
  auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 >= spec.size())
    throw Error("--relight '" + spec + "': expected NAME=env.exr");
  RelightEnv r{spec.substr(0, eq), spec.substr(eq + 1)};
  for (char c : r.name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'))
      throw Error("--relight '" + spec + "': NAME may only hold letters, digits, '_' and '-'");
  return r;
}

std::string metrics_markdown(const json& m) {
  std::ostringstream md;
  md << "| metric | ours | PTIR paper (TensoIR set, 800², reference only) |\n";
  md << "|---|---:|---:|\n";
  md << "| Albedo PSNR (dB, scale-aligned, sRGB, foreground) ↑ | " << fmt(m.value("albedo_psnr", json()), "%.2f")
     << " | |\n";
  md << "| Albedo PSNR (dB, TensoIR's protocol: white background, gamma 2.2) ↑ | "
     << fmt(m.value("albedo_psnr_tensoir", json()), "%.2f") << " | 32.12 |\n";
  md << "| NVS PSNR (dB) ↑ | " << fmt(m.value("nvs_psnr", json()), "%.2f") << " | 36.17 |\n";
  md << "| NVS SSIM ↑ | " << fmt(m.value("nvs_ssim", json()), "%.4f") << " | – |\n";
  if (!m.value("nvs_psnr_object", json()).is_null())
    md << "| NVS PSNR on the object (dB; the capture's coverage masks) ↑ | " << fmt(m["nvs_psnr_object"], "%.2f")
       << " | – |\n";
  const json relight = m.value("relight", json::object());
  md << "| Relight PSNR (dB, mean of " << relight.size() << ") ↑ | " << fmt(m.value("relight_psnr", json()), "%.2f")
     << " | 31.84 |\n";
  for (auto it = relight.begin(); it != relight.end(); ++it)
    md << "| &nbsp;&nbsp;relight " << it.key() << " PSNR / SSIM | " << fmt(it.value().value("psnr", json()), "%.2f")
       << " / " << fmt(it.value().value("ssim", json()), "%.4f") << " | |\n";
  md << "| Roughness MSE ↓ | " << fmt(m.value("roughness_mse", json()), "%.4f") << " | 0.015 |\n";
  md << "| Normal MAE (°) ↓ | " << fmt(m.value("normal_mae_deg", json()), "%.2f") << " | 4.03 |\n";
  const json env = m.value("environment", json());
  if (env.is_object())
    md << "| Environment PSNR (dB, scale-aligned; sky only) ↑ | " << fmt_db(env["psnr"]) << "; " << fmt_db(env["psnr_upper"])
       << " | |\n";
  return md.str();
}

namespace {

// Everything one evaluation accumulates, shared by its passes.
struct EvalRun {
  explicit EvalRun(const EvalSettings& settings) : s(settings) {}
  const EvalSettings& s;
  std::unique_ptr<Dataset> data;
  Scene scene;
  std::unique_ptr<PathTracer> tracer;
  IntegratorSettings is;
  AovSettings as;
  fs::path out;
  size_t n_views = 0, sheet_n = 0;
  std::map<std::string, std::vector<std::vector<Image>>> sheets;
  json per_view = json::array();
  std::vector<double> nvs_psnr, nvs_ssim, rough_mse, normal_mae, albedo_psnr, albedo_psnr_lin, relight_means;
  std::vector<double> nvs_psnr_object;  // a capture's object: its coverage masks (capture_object_mask)
  AlbedoRatios ratios;
  std::unique_ptr<TensoirAlbedoScore> tensoir;  // TensoIR's albedo protocol, beside ours
  bool have_albedo = false;
  std::array<double, 3> scale{1.0, 1.0, 1.0};
  json albedo_scale_json = nullptr, relight_json = json::object(), env_json = nullptr;
  double build_s = 0.0, render_s = 0.0;

  void say(const std::string& line) const {
    if (s.log) s.log(line);
  }
  GaussianField& field() { return *scene.gaussians; }
};

// 1 where the ground truth's alpha > 0.5 (the protocol's foreground).
Image foreground_mask(const Image& alpha) {
  Image m(alpha.width, alpha.height, {"Y"});
  for (size_t k = 0; k < m.pixels.size(); ++k) m.pixels[k] = alpha.pixels[k] > 0.5f ? 1.0f : 0.0f;
  return m;
}

// The scene: recovered Gaussians under the recovered environment (+ the scene file's
// meshes and lights), the tracer, normals oriented toward the test cameras.
void load_eval_scene(EvalRun& run) {
  const EvalSettings& s = run.s;
  const fs::path result(s.result);
  const fs::path ply = result / "gaussians.ply", env_path = result / "env.exr";
  if (!file_exists(ply))
    throw Error(ply.string(), "no such file (the result folder of `ptir optimize` holds gaussians.ply and env.exr)");
  if (!file_exists(env_path)) throw Error(env_path.string(), "no such file (the recovered environment)");
  DatasetOptions dopt = s.dataset_options;
  dopt.split = s.split;
  dopt.cache_bytes = 0;  // every image is read once
  run.data = load_dataset(s.dataset, dopt);
  if (run.data->size() == 0) throw Error(run.data->transforms_path, "no views");
  // A capture's result: its photos as the run read them (capture_result.h).
  if (dopt.calibration.empty()) read_photos_as_the_run_did(*run.data, s.result);
  Scene& scene = run.scene;
  if (!s.scene.empty()) {
    Scene extra = load_scene_json(s.scene);
    scene.meshes = std::move(extra.meshes);
    scene.emitters = std::move(extra.emitters);
    scene.integrator = extra.integrator;
    scene.brdf_from_file = extra.brdf_from_file;
  }
  *scene.gaussians = load_gaussians(ply.string());
  scene.environment = Environment::load(env_path.string());
  scene.cameras = run.data->cameras();
  scene.source_path = s.result;
}

void build_tracer(EvalRun& run) {
  const EvalSettings& s = run.s;
  const auto t_build = Clock::now();
  run.tracer = std::make_unique<PathTracer>(run.scene);
  GaussianField& field = run.field();
  if (!field.normals_from_file && field.size() > 0) orient_normals_to_cameras(field, run.tracer->accel(), run.scene.cameras);
  run.build_s = seconds_since(t_build);
  run.is = run.scene.integrator;
  // Scores with every light sampled at every vertex and no Russian roulette: less
  // noise per sample than Cycles' estimator, for ours and the oracle alike.
  run.is.light_selection = LightSelection::All;
  run.is.russian_roulette = false;
  run.is.spp = s.spp;
  run.is.max_bounces = s.bounces;
  // The model: --brdf, else the scene file's, else the dataset's recorded one, else principled-v2.
  run.is.brdf = resolve_bsdf_model(run.scene.brdf_from_file, run.is.brdf, run.data->brdf);
  if (s.brdf) run.is.brdf = *s.brdf;
  run.is.seed = s.seed;
  run.is.filter = dataset_pixel_filter(*run.data);
  if (s.filter_type) run.is.filter.type = *s.filter_type;
  if (s.filter_width) run.is.filter.width = *s.filter_width;
  PixelFilterSampler{run.is.filter};  // validates the width before any rendering
  run.as.filter = run.is.filter;
  run.as.spp = s.aov_spp;
  run.as.seed = s.seed;
  run.as.interaction = run.is.interaction;
  // Written whole into a staging folder, then in place of RESULT/eval (evaluate.h);
  // rank 0 alone writes. A staging folder left by a killed run goes first.
  run.out = fs::path(s.result) / kEvalStaging;
  if (s.comm->rank() == 0) {
    std::error_code ec;
    fs::remove_all(run.out, ec);
    make_folder(run.out);
  }
  run.n_views = run.data->size();
  run.sheet_n = std::min(run.n_views, size_t(std::max(0, s.sheet_views)));
}

// Roughness MSE and normal MAE of view i against its ground truth (where present).
void score_aovs(EvalRun& run, size_t i, const Image& mask, const Image& show, const TrainingImage& gt, const Image& rough,
                const Image& normal, json& v) {
  Image gt_rough = run.data->gt_roughness(i);
  if (gt_rough.width > 0) {
    double e = roughness_mse(gt_rough, rough, &mask);
    run.rough_mse.push_back(e);
    v["roughness_mse"] = e;
    if (i < run.sheet_n) {
      Image d(gt_rough.width, gt_rough.height, {"Y"});
      for (size_t k = 0; k < d.pixels.size(); ++k)
        d.pixels[k] = mask.pixels[k] > 0.5f ? std::fabs(gt_rough.pixels[k * gt_rough.channels] - rough.pixels[k * rough.channels]) : 0.0f;
      run.sheets["roughness"].push_back({grey_to_rgb(gt_rough, &gt.alpha), grey_to_rgb(rough, &rough),
                                         heatmap(d, kRoughnessErrorScale, &show)});
    }
  }
  Image gt_normal = run.data->gt_normal(i);
  if (gt_normal.width > 0) {
    double e = normal_mae_deg(gt_normal, normal, &mask);
    run.normal_mae.push_back(e);
    v["normal_mae_deg"] = e;
    if (i < run.sheet_n)
      run.sheets["normal"].push_back({normals_to_rgb(gt_normal, &gt.alpha), normals_to_rgb(normal, &normal),
                                      heatmap(angle_difference(gt_normal, normal), kNormalErrorScale, &show)});
  }
}

// A render of the whole view, split across the ranks of a data-parallel run.
Image render_split(const EvalRun& run, const Camera& cam, const std::function<Image(const Camera&)>& render) {
  return render_row_bands(*run.s.comm, cam, [&](const Camera& band, size_t) { return render(band); });
}

// Pass 1 for view i: the novel view and the AOVs, written and scored (by rank 0).
void evaluate_view(EvalRun& run, size_t i) {
  const EvalSettings& s = run.s;
  const PathTracer& tracer = *run.tracer;
  const Camera& cam = run.data->views[i].camera;
  const fs::path vdir = run.out / view_folder(i);
  if (s.comm->rank() == 0) make_folder(vdir);
  const auto t0 = Clock::now();
  std::shared_ptr<const TrainingImage> gt = run.data->target(i);
  // A capture without masks is unbounded: its photos show the environment behind the Gaussians, and
  // the render does too (rgba.exr then holds an opaque picture, A = 1 where an environment is seen:
  // docs/alpha.md); with a mask or alpha, the object on a transparent film (associated RGBA)
  // composited over white (docs/method.md §7).
  const bool unbounded = !gt->has_alpha;
  auto aov = [&](Aov a) {
    return render_split(run, cam, [&](const Camera& c) { return render_aov(tracer.accel(), c, a, run.as, s.control); });
  };
  Image rgba = render_split(run, cam, [&](const Camera& c) {
    return unbounded ? render_path(tracer, c, run.is, s.control) : render_transparent(tracer, c, run.is, s.control);
  });
  Image albedo = aov(Aov::Albedo), rough = aov(Aov::Roughness), metal = aov(Aov::Metallic), normal = aov(Aov::Normal);
  // The albedo scores compare Blender's Diffuse Color pass (the datasets' albedo
  // ground truth) with ours: base colour x (1 - metallic), the base colour where
  // metallic is 0 (a metal's diffuse colour is black in both).
  Image diffuse = aov(Aov::DiffuseColor);
  run.render_s += seconds_since(t0);
  if (s.comm->rank() != 0) return;
  if (unbounded) {
    Image opaque = rgba;
    set_film_alpha(opaque, false, tracer.scene().environment.present());
    write_image((vdir / "rgba.exr").string(), opaque);
  } else {
    write_image((vdir / "rgba.exr").string(), rgba);
  }
  write_image((vdir / "albedo.exr").string(), albedo);
  write_image((vdir / "diffuse_color.exr").string(), diffuse);
  write_image((vdir / "roughness.exr").string(), rough);
  write_image((vdir / "metallic.exr").string(), metal);
  write_image((vdir / "normal.exr").string(), normal);

  json v = {{"view", view_folder(i)}, {"camera", cam.name}};
  const Image mask = foreground_mask(gt->alpha);
  const Image show = union_mask(mask, rgba);
  Image ours_rgb = unbounded ? Image(rgba.width, rgba.height, {"R", "G", "B"}) : unpremultiply(rgba);
  if (unbounded)
    for (size_t p = 0, n = size_t(rgba.width) * rgba.height; p < n; ++p)
      for (int c = 0; c < 3; ++c) ours_rgb.pixels[3 * p + c] = rgba.pixels[4 * p + c];
  const Image ours_disp = composite_srgb(ours_rgb, unbounded ? nullptr : &rgba);
  const Image gt_disp = composite_srgb(gt->rgb, &gt->alpha);
  double p = capped(psnr(ours_disp, gt_disp)), q = ssim(ours_disp, gt_disp);
  run.nvs_psnr.push_back(p);
  run.nvs_ssim.push_back(q);
  v["nvs_psnr"] = p;
  v["nvs_ssim"] = q;
  // A capture's object against its background: the photo's pixels the input splat covers too.
  const Image object = unbounded ? capture_object_mask(s.result, cam.name, rgba.width, rgba.height) : Image();
  if (object.width > 0) {
    const double po = capped(psnr(ours_disp, gt_disp, &object));
    run.nvs_psnr_object.push_back(po);
    v["nvs_psnr_object"] = po;
  }
  if (i < run.sheet_n)
    run.sheets["nvs"].push_back({gt_disp, ours_disp, heatmap(abs_difference(gt_disp, ours_disp), kColourErrorScale, &show)});

  Image gt_albedo = run.data->gt_albedo(i);
  if (gt_albedo.width == 0 && i < run.sheet_n)  // photos without material truth: what was recovered, beside them
    run.sheets["materials"].push_back({gt_disp, composite_srgb(albedo, &albedo), grey_to_rgb(rough, &rough),
                                       normals_to_rgb(normal, &normal)});
  if (gt_albedo.width > 0) {
    run.have_albedo = true;
    run.ratios.add(gt_albedo, diffuse, mask);
    if (!run.tensoir) run.tensoir = std::make_unique<TensoirAlbedoScore>(run.n_views);
    run.tensoir->add_ratios(i, gt_albedo, diffuse, gt->alpha);
  }
  score_aovs(run, i, mask, show, *gt, rough, normal, v);
  const bool has_normal_gt = v.contains("normal_mae_deg");
  run.per_view.push_back(v);
  char line[256];
  std::snprintf(line, sizeof line, "eval %s: NVS %.2f dB / SSIM %.4f%s", view_folder(i).c_str(), p, q,
                has_normal_gt ? "" : " (no normal ground truth)");
  run.say(line);
}

// The albedo scale over all views, then the albedo PSNR per view (our AOV read back).
void score_albedo(EvalRun& run) {
  if (!run.have_albedo) return;
  run.scale = run.ratios.scale();
  run.ratios = AlbedoRatios();
  run.albedo_scale_json = {run.scale[0], run.scale[1], run.scale[2]};
  const std::array<double, 3> tensoir_scale = run.tensoir->scale();
  for (size_t i = 0; i < run.n_views; ++i) {
    Image gt_albedo = run.data->gt_albedo(i);
    if (gt_albedo.width == 0) continue;
    std::shared_ptr<const TrainingImage> gt = run.data->target(i);
    const Image mask = foreground_mask(gt->alpha);
    Image pred = read_image((run.out / view_folder(i) / "diffuse_color.exr").string(), Encoding::Data);
    run.tensoir->add_error(gt_albedo, pred, gt->alpha, tensoir_scale);
    Image aligned = apply_scale(pred, run.scale);
    Image gt_clamped = apply_scale(gt_albedo, {1.0, 1.0, 1.0});
    Image a_srgb = srgb_encode(aligned), g_srgb = srgb_encode(gt_clamped);
    double p = capped(psnr(a_srgb, g_srgb, &mask)), pl = capped(psnr(aligned, gt_clamped, &mask));
    run.albedo_psnr.push_back(p);
    run.albedo_psnr_lin.push_back(pl);
    run.per_view[i]["albedo_psnr"] = p;
    run.per_view[i]["albedo_psnr_linear"] = pl;
    if (i < run.sheet_n)
      run.sheets["albedo"].push_back({composite_srgb(gt_albedo, &gt->alpha), composite_srgb(aligned, &pred),
                                      heatmap(abs_difference(a_srgb, g_srgb), kColourErrorScale, &mask)});
  }
  char line[160];
  std::snprintf(line, sizeof line, "eval: albedo scale %.4f %.4f %.4f, albedo PSNR %.2f dB", run.scale[0], run.scale[1],
                run.scale[2], mean_or_null(run.albedo_psnr).get<double>());
  run.say(line);
}

// Every view relit under one environment (the albedo already scaled), scored where
// the relit ground truth exists.
void relight_views(EvalRun& run, const RelightEnv& r, const Environment& env) {
  run.scene.environment = env;
  std::vector<double> ps, ss;
  for (size_t i = 0; i < run.n_views; ++i) {
    const Camera& cam = run.data->views[i].camera;
    const auto t0 = Clock::now();
    Image rgba = render_split(
        run, cam, [&](const Camera& c) { return render_transparent(*run.tracer, c, run.is, run.s.control); });
    run.render_s += seconds_since(t0);
    if (run.s.comm->rank() != 0) continue;
    write_image((run.out / view_folder(i) / ("rgba_" + r.name + ".exr")).string(), rgba);
    std::string gt_path = relight_gt_path(run.data->views[i].files.image, r.name);
    if (gt_path.empty()) continue;
    TrainingImage gt = read_training_image(gt_path);
    if (gt.rgb.width != rgba.width || gt.rgb.height != rgba.height) throw Error(gt_path, "size differs from the view's camera");
    const Image ours_disp = composite_srgb(unpremultiply(rgba), &rgba);
    const Image gt_disp = composite_srgb(gt.rgb, &gt.alpha);
    double p = capped(psnr(ours_disp, gt_disp)), q = ssim(ours_disp, gt_disp);
    ps.push_back(p);
    ss.push_back(q);
    run.per_view[i]["relight"][r.name] = {{"psnr", p}, {"ssim", q}};
    if (i < run.sheet_n) {
      Image show = union_mask(foreground_mask(gt.alpha), rgba);
      run.sheets["relight_" + r.name].push_back(
          {gt_disp, ours_disp, heatmap(abs_difference(gt_disp, ours_disp), kColourErrorScale, &show)});
    }
  }
  json e = {{"env", r.path}, {"psnr", mean_or_null(ps)}, {"ssim", mean_or_null(ss)}, {"views", ps.size()}};
  run.relight_json[r.name] = e;
  if (!ps.empty()) run.relight_means.push_back(e["psnr"].get<double>());
  char line[200];
  std::snprintf(line, sizeof line, "eval: relight %s: %s", r.name.c_str(),
                ps.empty() ? "rendered (no ground truth)" : (fmt(e["psnr"], "%.2f") + " dB").c_str());
  run.say(line);
}

// The recovered environment against the dataset's training environment, when it
// records one (env_score.h): metrics and sheet_environment.png.
void score_recovered_environment(EvalRun& run, std::vector<std::string>& sheet_files) {
  const std::string gt_path = dataset_training_environment(run.s.dataset);
  const fs::path ours_path = fs::path(run.s.result) / "env.exr";
  if (gt_path.empty() || !file_exists(ours_path.string())) return;
  const EnvScore e = score_environment(read_image(ours_path.string(), Encoding::Data), read_image(gt_path, Encoding::Data));
  run.env_json = {{"psnr", e.psnr}, {"psnr_upper", e.psnr_upper}, {"scale", {e.scale[0], e.scale[1], e.scale[2]}},
                  {"truth", absolute_path(gt_path)},
                  {"protocol", "per-channel solid-angle energy match, Reinhard + sRGB display, solid-angle weighted"}};
  if (run.s.sheet_views > 0) {
    write_image((run.out / "sheet_environment.png").string(), e.sheet, Encoding::Data);
    sheet_files.push_back("sheet_environment.png");
  }
  char line[160];
  std::snprintf(line, sizeof line, "eval: environment PSNR %.2f dB (sky %.2f dB) after scale %.3f %.3f %.3f", e.psnr,
                e.psnr_upper, e.scale[0], e.scale[1], e.scale[2]);
  run.say(line);
}

// Contact sheets, upscaled so that small images are still legible; returns their file names.
std::vector<std::string> write_contact_sheets(const EvalRun& run) {
  std::vector<std::string> sheet_files;
  for (auto& [name, rows] : run.sheets) {
    if (rows.empty()) continue;
    const int tile = rows[0][0].width;
    const int k = std::max(1, 256 / std::max(1, tile));
    fs::path f = run.out / ("sheet_" + name + ".png");
    write_image(f.string(), contact_sheet(rows, std::min(k, 4)), Encoding::Data);
    sheet_files.push_back(f.filename().string());
  }
  return sheet_files;
}

json metrics_json(const EvalRun& run, const std::vector<std::string>& sheet_files, double total_s) {
  const EvalSettings& s = run.s;
  json m;
  m["dataset"] = absolute_path(s.dataset);
  m["result"] = absolute_path(s.result);
  m["split"] = s.split;
  m["views"] = run.n_views;
  m["gaussians"] = run.scene.gaussians->size();
  m["settings"] = {{"spp", s.spp}, {"bounces", s.bounces}, {"aov_spp", s.aov_spp}, {"seed", s.seed},
                   {"background", "white (sRGB composite)"}, {"foreground", "ground-truth alpha > 0.5"}};
  m["albedo_scale"] = run.albedo_scale_json;
  m["albedo_psnr"] = mean_or_null(run.albedo_psnr);
  m["albedo_psnr_linear"] = mean_or_null(run.albedo_psnr_lin);
  m["albedo_psnr_tensoir"] = run.tensoir ? json(run.tensoir->psnr()) : json(nullptr);
  m["nvs_psnr"] = mean_or_null(run.nvs_psnr);
  m["nvs_ssim"] = mean_or_null(run.nvs_ssim);
  m["nvs_psnr_object"] = mean_or_null(run.nvs_psnr_object);
  m["relight"] = run.relight_json;
  m["relight_psnr"] = mean_or_null(run.relight_means);
  m["roughness_mse"] = mean_or_null(run.rough_mse);
  m["normal_mae_deg"] = mean_or_null(run.normal_mae);
  m["environment"] = run.env_json;
  m["per_view"] = run.per_view;
  m["sheets"] = sheet_files;
  m["seconds"] = {{"build", run.build_s}, {"render", run.render_s}, {"total", total_s}};
  return m;
}

std::string report_markdown(const EvalRun& run, const json& m) {
  const EvalSettings& s = run.s;
  const std::array<double, 3>& scale = run.scale;
  std::ostringstream md;
  md << "# Evaluation of " << m["result"].get<std::string>() << "\n\n";
  md << "Dataset `" << m["dataset"].get<std::string>() << "`, " << run.n_views << " " << s.split << " views, "
     << run.scene.gaussians->size() << " Gaussians; renders " << s.spp << " spp, " << s.bounces << " bounces; AOVs "
     << s.aov_spp << " spp.\n\n";
  md << metrics_markdown(m);
  md << "\nAlbedo scale (per channel, median gt/ours, linear): ";
  md << (run.have_albedo
             ? fmt(json(scale[0]), "%.4f") + " " + fmt(json(scale[1]), "%.4f") + " " + fmt(json(scale[2]), "%.4f")
             : std::string("n/a (no albedo ground truth)"))
     << ".\n\nProtocol (docs/method.md §7): NVS/relight compare sRGB display values composited over white, "
        "whole image "
        "(photos without masks: against the render with the environment behind); "
        "albedo PSNR over foreground pixels (gt alpha > 0.5) after the scale, in sRGB (linear: "
     << fmt(m["albedo_psnr_linear"], "%.2f")
     << " dB); roughness MSE over the whole image with the background zeroed; normal MAE over foreground pixels. "
        "Relighting uses the scaled albedo. PSNR of identical images is reported as 100 dB.\n\n"
        "Contact sheets (rows = views; columns = ground truth | ours | error): colour error full scale = 0.25 "
        "(sRGB display difference), roughness 0.5, normal 45°. Views without material ground truth (photos): "
        "sheet_materials.png, photo | albedo | roughness | normal.\n";
  return md.str();
}

EvalReport evaluate_unguarded(const EvalSettings& s) {
  const auto t_start = Clock::now();
  if (s.spp < 1 || s.aov_spp < 1) throw Error("eval: samples per pixel must be at least 1");
  if (s.bounces < 0) throw Error("eval: bounces must be at least 0");
  EvalRun run(s);
  load_eval_scene(run);
  std::vector<std::pair<RelightEnv, Environment>> relights;
  for (const RelightEnv& r : s.relight) {
    for (const auto& other : relights)
      if (other.first.name == r.name) throw Error("--relight: the name '" + r.name + "' is given twice");
    relights.emplace_back(r, Environment::load(r.path));
  }
  build_tracer(run);
  for (size_t i = 0; i < run.n_views; ++i) evaluate_view(run, i);
  const Communicator& comm = *s.comm;
  if (comm.rank() == 0) score_albedo(run);  // reads back what rank 0 wrote
  comm.broadcast(run.scale.data(), sizeof run.scale, 0);
  if (!relights.empty()) {
    scale_albedo(run.field(), run.scale);
    for (const auto& [r, env] : relights) relight_views(run, r, env);
  }
  if (comm.rank() != 0) return {};
  std::vector<std::string> sheet_files = write_contact_sheets(run);
  score_recovered_environment(run, sheet_files);

  EvalReport rep;
  rep.metrics = metrics_json(run, sheet_files, seconds_since(t_start));
  rep.markdown = report_markdown(run, rep.metrics);
  io::write_text_atomic((run.out / "metrics.json").string(), rep.metrics.dump(1) + "\n");
  io::write_text_atomic((run.out / "metrics.md").string(), rep.markdown);
  rep.out_dir = (fs::path(s.result) / "eval").string();
  io::replace_folder(run.out.string(), rep.out_dir);
  return rep;
}

}  // namespace

EvalReport evaluate(const EvalSettings& s) {
  // A failed evaluation leaves RESULT/eval as it was, and no staging folder.
  auto drop_staging = [&] {
    std::error_code ec;
    if (s.comm->rank() == 0) fs::remove_all(fs::path(s.result) / kEvalStaging, ec);
  };
  try {
    return evaluate_unguarded(s);
  } catch (const fs::filesystem_error& e) {
    drop_staging();
    // Any filesystem failure not already reported (readers, writers) names its path.
    throw Error(e.path1().empty() ? s.result : e.path1().string(), e.code().message());
  } catch (...) {
    drop_staging();
    throw;
  }
}

}  // namespace ptir::eval
