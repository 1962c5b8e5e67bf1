#include "ptir/eval/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/eval/contact_sheet.h"
#include "ptir/eval/metrics.h"
#include "ptir/eval/relight.h"
#include "ptir/scene/dataset.h"
#include "ptir/render/aov.h"
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
    if (fs::exists(a)) return a.string();
    fs::path b = p.parent_path() / (p.stem().string() + "_" + name + ext);
    if (fs::exists(b)) return b.string();
  }
  return "";
}

// Accumulates gt/pred ratios for the albedo scale without keeping images.
struct RatioAccumulator {
  std::array<std::vector<float>, 3> ratios;
  void add(const Image& gt, const Image& pred, const Image& mask) {
    for (int y = 0; y < gt.height; ++y)
      for (int x = 0; x < gt.width; ++x) {
        if (mask.at(x, y, 0) <= 0.5f) continue;
        for (int c = 0; c < 3; ++c) ratios[c].push_back(gt.at(x, y, c) / std::max(pred.at(x, y, c), 1e-6f));
      }
  }
  std::array<double, 3> scale() {
    std::array<double, 3> s{1.0, 1.0, 1.0};
    for (int c = 0; c < 3; ++c)
      if (!ratios[c].empty()) s[c] = median(ratios[c]);
    return s;
  }
};

void write_text(const fs::path& path, const std::string& text) {
  fs::path tmp = path;
  tmp += ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) throw Error(path.string(), "cannot write");
    f << text;
    if (!f) throw Error(path.string(), "write failed");
  }
  fs::rename(tmp, path);
}

std::string fmt(const json& v, const char* f) {
  if (v.is_null()) return "n/a";
  char b[64];
  std::snprintf(b, sizeof b, f, v.get<double>());
  return b;
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
  md << "| Albedo PSNR (dB, scale-aligned, sRGB) ↑ | " << fmt(m.value("albedo_psnr", json()), "%.2f") << " | 32.12 |\n";
  md << "| NVS PSNR (dB) ↑ | " << fmt(m.value("nvs_psnr", json()), "%.2f") << " | 36.17 |\n";
  md << "| NVS SSIM ↑ | " << fmt(m.value("nvs_ssim", json()), "%.4f") << " | – |\n";
  const json relight = m.value("relight", json::object());
  md << "| Relight PSNR (dB, mean of " << relight.size() << ") ↑ | " << fmt(m.value("relight_psnr", json()), "%.2f")
     << " | 31.84 |\n";
  for (auto it = relight.begin(); it != relight.end(); ++it)
    md << "| &nbsp;&nbsp;relight " << it.key() << " PSNR / SSIM | " << fmt(it.value().value("psnr", json()), "%.2f")
       << " / " << fmt(it.value().value("ssim", json()), "%.4f") << " | |\n";
  md << "| Roughness MSE ↓ | " << fmt(m.value("roughness_mse", json()), "%.4f") << " | 0.015 |\n";
  md << "| Normal MAE (°) ↓ | " << fmt(m.value("normal_mae_deg", json()), "%.2f") << " | 4.03 |\n";
  return md.str();
}

EvalReport evaluate(const EvalSettings& s) {
  const auto t_start = Clock::now();
  auto say = [&](const std::string& line) {
    if (s.log) s.log(line);
  };
  if (s.spp < 1 || s.aov_spp < 1) throw Error("eval: samples per pixel must be at least 1");
  if (s.bounces < 0) throw Error("eval: bounces must be at least 0");
  const fs::path result(s.result);
  const fs::path ply = result / "gaussians.ply", env_path = result / "env.exr";
  if (!fs::exists(ply)) throw Error(ply.string(), "no such file (the result folder of `ptir optimize` holds gaussians.ply and env.exr)");
  if (!fs::exists(env_path)) throw Error(env_path.string(), "no such file (the recovered environment)");

  DatasetOptions dopt;
  dopt.split = s.split;
  dopt.cache_bytes = 0;  // every image is read once
  std::unique_ptr<Dataset> data = load_dataset(s.dataset, dopt);
  if (data->size() == 0) throw Error(data->transforms_path, "no views");

  // The scene: recovered Gaussians under the recovered environment (+ the scene file's meshes and lights).
  Scene scene;
  if (!s.scene.empty()) {
    Scene extra = load_scene_json(s.scene);
    scene.meshes = std::move(extra.meshes);
    scene.emitters = std::move(extra.emitters);
    scene.integrator = extra.integrator;
  }
  *scene.gaussians = load_gaussians(ply.string());
  GaussianField& field = *scene.gaussians;
  scene.environment.latlong = Environment::load(env_path.string());
  scene.cameras = data->cameras();
  scene.source_path = s.result;
  std::vector<std::pair<RelightEnv, Environment>> relights;
  for (const RelightEnv& r : s.relight) {
    for (const auto& other : relights)
      if (other.first.name == r.name) throw Error("--relight: the name '" + r.name + "' is given twice");
    relights.emplace_back(r, Environment::load(r.path));
  }

  const auto t_build = Clock::now();
  PathTracer tracer(scene);
  if (!field.normals_from_file && field.size() > 0) orient_normals_to_cameras(field, tracer.accel(), scene.cameras);
  const double build_s = seconds_since(t_build);

  IntegratorSettings is = scene.integrator;
  is.spp = s.spp;
  is.max_bounces = s.bounces;
  if (s.brdf) is.brdf = *s.brdf;
  is.seed = s.seed;
  is.filter = dataset_pixel_filter(*data);
  if (s.filter_type) is.filter.type = *s.filter_type;
  if (s.filter_width) is.filter.width = *s.filter_width;
  PixelFilterSampler{is.filter};  // validates the width before any rendering
  AovSettings as;
  as.filter = is.filter;
  as.spp = s.aov_spp;
  as.seed = s.seed;
  as.interaction = is.interaction;

  const fs::path out = result / "eval";
  fs::create_directories(out);
  const size_t n_views = data->size();
  const size_t sheet_n = std::min(n_views, size_t(std::max(0, s.sheet_views)));
  std::map<std::string, std::vector<std::vector<Image>>> sheets;

  json per_view = json::array();
  std::vector<double> nvs_psnr, nvs_ssim, rough_mse, normal_mae;
  RatioAccumulator ratios;
  bool have_albedo = false;
  double render_s = 0.0;

  // Pass 1: novel views and AOVs.
  for (size_t i = 0; i < n_views; ++i) {
    const Camera& cam = data->views[i].camera;
    const fs::path vdir = out / view_folder(i);
    fs::create_directories(vdir);
    const auto t0 = Clock::now();
    Image rgba = render_transparent(tracer, cam, is, s.control);
    Image albedo = render_aov(tracer.accel(), cam, Aov::Albedo, as, s.control);
    Image rough = render_aov(tracer.accel(), cam, Aov::Roughness, as, s.control);
    Image metal = render_aov(tracer.accel(), cam, Aov::Metallic, as, s.control);
    Image normal = render_aov(tracer.accel(), cam, Aov::Normal, as, s.control);
    render_s += seconds_since(t0);
    write_image((vdir / "rgba.exr").string(), rgba);
    write_image((vdir / "albedo.exr").string(), albedo);
    write_image((vdir / "roughness.exr").string(), rough);
    write_image((vdir / "metallic.exr").string(), metal);
    write_image((vdir / "normal.exr").string(), normal);

    json v = {{"view", view_folder(i)}, {"camera", cam.name}};
    std::shared_ptr<const TrainingImage> gt = data->target(i);
    const Image mask = [&] {
      Image m(gt->alpha.width, gt->alpha.height, {"Y"});
      for (size_t k = 0; k < m.pixels.size(); ++k) m.pixels[k] = gt->alpha.pixels[k] > 0.5f ? 1.0f : 0.0f;
      return m;
    }();
    const Image show = union_mask(mask, rgba);
    const Image ours_rgb = unpremultiply(rgba);
    const Image ours_disp = composite_srgb(ours_rgb, &rgba);
    const Image gt_disp = composite_srgb(gt->rgb, &gt->alpha);
    double p = capped(psnr(ours_disp, gt_disp)), q = ssim(ours_disp, gt_disp);
    nvs_psnr.push_back(p);
    nvs_ssim.push_back(q);
    v["nvs_psnr"] = p;
    v["nvs_ssim"] = q;
    if (i < sheet_n) sheets["nvs"].push_back({gt_disp, ours_disp, heatmap(abs_difference(gt_disp, ours_disp), kColourErrorScale, &show)});

    Image gt_albedo = data->gt_albedo(i);
    if (gt_albedo.width > 0) {
      have_albedo = true;
      ratios.add(gt_albedo, albedo, mask);
    }
    Image gt_rough = data->gt_roughness(i);
    if (gt_rough.width > 0) {
      double e = roughness_mse(gt_rough, rough, &mask);
      rough_mse.push_back(e);
      v["roughness_mse"] = e;
      if (i < sheet_n) {
        Image d(gt_rough.width, gt_rough.height, {"Y"});
        for (size_t k = 0; k < d.pixels.size(); ++k)
          d.pixels[k] = mask.pixels[k] > 0.5f ? std::fabs(gt_rough.pixels[k * gt_rough.channels] - rough.pixels[k * rough.channels]) : 0.0f;
        sheets["roughness"].push_back({grey_to_rgb(gt_rough, &gt->alpha), grey_to_rgb(rough, &rough),
                                       heatmap(d, kRoughnessErrorScale, &show)});
      }
    }
    Image gt_normal = data->gt_normal(i);
    if (gt_normal.width > 0) {
      double e = normal_mae_deg(gt_normal, normal, &mask);
      normal_mae.push_back(e);
      v["normal_mae_deg"] = e;
      if (i < sheet_n)
        sheets["normal"].push_back({normals_to_rgb(gt_normal, &gt->alpha), normals_to_rgb(normal, &normal),
                                    heatmap(angle_difference(gt_normal, normal), kNormalErrorScale, &show)});
    }
    per_view.push_back(v);
    char line[256];
    std::snprintf(line, sizeof line, "eval %s: NVS %.2f dB / SSIM %.4f%s", view_folder(i).c_str(), p, q,
                  gt_normal.width > 0 ? "" : " (no normal ground truth)");
    say(line);
  }

  // Albedo scale over all views, then the albedo PSNR per view (our AOV read back).
  json albedo_scale_json = nullptr;
  std::array<double, 3> scale{1.0, 1.0, 1.0};
  std::vector<double> albedo_psnr, albedo_psnr_lin;
  if (have_albedo) {
    scale = ratios.scale();
    ratios = RatioAccumulator();
    albedo_scale_json = {scale[0], scale[1], scale[2]};
    for (size_t i = 0; i < n_views; ++i) {
      Image gt_albedo = data->gt_albedo(i);
      if (gt_albedo.width == 0) continue;
      std::shared_ptr<const TrainingImage> gt = data->target(i);
      Image mask(gt->alpha.width, gt->alpha.height, {"Y"});
      for (size_t k = 0; k < mask.pixels.size(); ++k) mask.pixels[k] = gt->alpha.pixels[k] > 0.5f ? 1.0f : 0.0f;
      Image pred = read_image((out / view_folder(i) / "albedo.exr").string(), Encoding::Data);
      Image aligned = apply_scale(pred, scale);
      Image gt_clamped = apply_scale(gt_albedo, {1.0, 1.0, 1.0});
      Image a_srgb = srgb_encode(aligned), g_srgb = srgb_encode(gt_clamped);
      double p = capped(psnr(a_srgb, g_srgb, &mask)), pl = capped(psnr(aligned, gt_clamped, &mask));
      albedo_psnr.push_back(p);
      albedo_psnr_lin.push_back(pl);
      per_view[i]["albedo_psnr"] = p;
      per_view[i]["albedo_psnr_linear"] = pl;
      if (i < sheet_n) {
        sheets["albedo"].push_back({composite_srgb(gt_albedo, &gt->alpha), composite_srgb(aligned, &pred),
                                    heatmap(abs_difference(a_srgb, g_srgb), kColourErrorScale, &mask)});
      }
    }
    char line[160];
    std::snprintf(line, sizeof line, "eval: albedo scale %.4f %.4f %.4f, albedo PSNR %.2f dB", scale[0], scale[1], scale[2],
                  mean_or_null(albedo_psnr).get<double>());
    say(line);
  }

  // Relighting with the scaled albedo.
  json relight_json = json::object();
  std::vector<double> relight_means;
  if (!relights.empty()) {
    scale_albedo(field, scale);
    for (auto& [r, env] : relights) {
      scene.environment.latlong = env;
      std::vector<double> ps, ss;
      for (size_t i = 0; i < n_views; ++i) {
        const Camera& cam = data->views[i].camera;
        const auto t0 = Clock::now();
        Image rgba = render_transparent(tracer, cam, is, s.control);
        render_s += seconds_since(t0);
        write_image((out / view_folder(i) / ("rgba_" + r.name + ".exr")).string(), rgba);
        std::string gt_path = relight_gt_path(data->views[i].files.image, r.name);
        if (gt_path.empty()) continue;
        TrainingImage gt = read_training_image(gt_path);
        if (gt.rgb.width != rgba.width || gt.rgb.height != rgba.height)
          throw Error(gt_path, "size differs from the view's camera");
        const Image ours_disp = composite_srgb(unpremultiply(rgba), &rgba);
        const Image gt_disp = composite_srgb(gt.rgb, &gt.alpha);
        double p = capped(psnr(ours_disp, gt_disp)), q = ssim(ours_disp, gt_disp);
        ps.push_back(p);
        ss.push_back(q);
        per_view[i]["relight"][r.name] = {{"psnr", p}, {"ssim", q}};
        if (i < sheet_n) {
          Image mask(gt.alpha.width, gt.alpha.height, {"Y"});
          for (size_t k = 0; k < mask.pixels.size(); ++k) mask.pixels[k] = gt.alpha.pixels[k] > 0.5f ? 1.0f : 0.0f;
          Image show = union_mask(mask, rgba);
          sheets["relight_" + r.name].push_back(
              {gt_disp, ours_disp, heatmap(abs_difference(gt_disp, ours_disp), kColourErrorScale, &show)});
        }
      }
      json e = {{"env", r.path}, {"psnr", mean_or_null(ps)}, {"ssim", mean_or_null(ss)}, {"views", ps.size()}};
      relight_json[r.name] = e;
      if (!ps.empty()) relight_means.push_back(e["psnr"].get<double>());
      char line[200];
      std::snprintf(line, sizeof line, "eval: relight %s: %s", r.name.c_str(),
                    ps.empty() ? "rendered (no ground truth)" : (fmt(e["psnr"], "%.2f") + " dB").c_str());
      say(line);
    }
  }

  // Contact sheets: upscaled so that small images are still legible.
  std::vector<std::string> sheet_files;
  for (auto& [name, rows] : sheets) {
    if (rows.empty()) continue;
    const int tile = rows[0][0].width;
    const int k = std::max(1, 256 / std::max(1, tile));
    fs::path f = out / ("sheet_" + name + ".png");
    write_image(f.string(), contact_sheet(rows, std::min(k, 4)), Encoding::Data);
    sheet_files.push_back(f.filename().string());
  }

  json m;
  m["dataset"] = fs::absolute(s.dataset).string();
  m["result"] = fs::absolute(s.result).string();
  m["split"] = s.split;
  m["views"] = n_views;
  m["gaussians"] = field.size();
  m["settings"] = {{"spp", s.spp}, {"bounces", s.bounces}, {"aov_spp", s.aov_spp}, {"seed", s.seed},
                   {"background", "white (sRGB composite)"}, {"foreground", "ground-truth alpha > 0.5"}};
  m["albedo_scale"] = albedo_scale_json;
  m["albedo_psnr"] = mean_or_null(albedo_psnr);
  m["albedo_psnr_linear"] = mean_or_null(albedo_psnr_lin);
  m["nvs_psnr"] = mean_or_null(nvs_psnr);
  m["nvs_ssim"] = mean_or_null(nvs_ssim);
  m["relight"] = relight_json;
  m["relight_psnr"] = mean_or_null(relight_means);
  m["roughness_mse"] = mean_or_null(rough_mse);
  m["normal_mae_deg"] = mean_or_null(normal_mae);
  m["per_view"] = per_view;
  m["sheets"] = sheet_files;
  m["seconds"] = {{"build", build_s}, {"render", render_s}, {"total", seconds_since(t_start)}};

  EvalReport rep;
  rep.metrics = m;
  std::ostringstream md;
  md << "# Evaluation of " << m["result"].get<std::string>() << "\n\n";
  md << "Dataset `" << m["dataset"].get<std::string>() << "`, " << n_views << " " << s.split << " views, " << field.size()
     << " Gaussians; renders " << s.spp << " spp, " << s.bounces << " bounces; AOVs " << s.aov_spp << " spp.\n\n";
  md << metrics_markdown(m);
  md << "\nAlbedo scale (per channel, median gt/ours, linear): ";
  md << (have_albedo ? fmt(json(scale[0]), "%.4f") + " " + fmt(json(scale[1]), "%.4f") + " " + fmt(json(scale[2]), "%.4f")
                     : std::string("n/a (no albedo ground truth)"))
     << ".\n\nProtocol (METHOD §7): NVS/relight compare sRGB display values composited over white, whole image; "
        "albedo PSNR over foreground pixels (gt alpha > 0.5) after the scale, in sRGB (linear: "
     << fmt(m["albedo_psnr_linear"], "%.2f")
     << " dB); roughness MSE over the whole image with the background zeroed; normal MAE over foreground pixels. "
        "Relighting uses the scaled albedo. PSNR of identical images is reported as 100 dB.\n\n"
        "Contact sheets (rows = views; columns = ground truth | ours | error): colour error full scale = 0.25 "
        "(sRGB display difference), roughness 0.5, normal 45°.\n";
  rep.markdown = md.str();
  rep.out_dir = out.string();
  write_text(out / "metrics.json", m.dump(1) + "\n");
  write_text(out / "metrics.md", rep.markdown);
  return rep;
}

}  // namespace ptir::eval
