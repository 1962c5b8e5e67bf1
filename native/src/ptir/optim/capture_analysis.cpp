#include "ptir/optim/capture_analysis.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/lights/environment.h"
#include "ptir/render/splat_composite.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

constexpr float kInner = 0.95f;       // coverage of the object's inner pixels (the gains)
constexpr float kBackground = 0.02f;  // coverage under which a pixel is background
constexpr int kBorder = 2;            // pixels of background next to the object left out
constexpr size_t kMinPixels = 64;     // inner pixels a photo's gain needs
constexpr double kSeenPixels = 16.0;  // photo pixels that make an environment texel seen (known)

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + long(h), v.end());
  return v[h];
}

double std_of(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  double m = 0.0, s = 0.0;
  for (double x : v) m += x;
  m /= double(v.size());
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / double(v.size() - 1));
}

// The photo's gain against the splat per channel: the median log ratio over inner pixels.
ViewPhotometry photometry(const SplatImage& fwd, const TrainingImage& photo, double exposure) {
  ViewPhotometry p;
  std::array<std::vector<double>, 3> logs;
  const size_t n = size_t(fwd.opacity.width) * size_t(fwd.opacity.height);
  size_t covered = 0;
  for (size_t i = 0; i < n; ++i) {
    const float o = fwd.opacity.pixels[i];
    covered += o > 0.5f;
    if (o < kInner) continue;
    std::array<double, 3> lr{};
    bool ok = true;
    for (int c = 0; c < 3; ++c) {
      const float s = srgb_to_linear(std::clamp(fwd.colour.pixels[3 * i + size_t(c)] / o, 0.0f, 1.0f));
      const double raw = double(photo.rgb.pixels[3 * i + size_t(c)]) * exposure;  // the photo as stored
      if (!(s > 0.01f && raw > 0.002)) ok = false;
      else lr[size_t(c)] = std::log(raw / double(s));
    }
    if (!ok) continue;
    for (int c = 0; c < 3; ++c) logs[size_t(c)].push_back(lr[size_t(c)]);
  }
  p.covered = double(covered) / double(std::max<size_t>(1, n));
  p.pixels = logs[0].size();
  for (int c = 0; c < 3; ++c) p.gain[size_t(c)] = p.pixels >= kMinPixels ? std::exp(median_of(logs[size_t(c)])) : 0.0;
  return p;
}

// Background pixels: coverage under kBackground within kBorder pixels.
std::vector<uint8_t> background_pixels(const Image& opacity) {
  const int W = opacity.width, H = opacity.height;
  std::vector<uint8_t> bg(size_t(W) * size_t(H), 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      bool clear = true;
      for (int dy = -kBorder; dy <= kBorder && clear; ++dy)
        for (int dx = -kBorder; dx <= kBorder && clear; ++dx) {
          const int xx = std::clamp(x + dx, 0, W - 1), yy = std::clamp(y + dy, 0, H - 1);
          clear = opacity.at(xx, yy, 0) < kBackground;
        }
      bg[size_t(y) * size_t(W) + size_t(x)] = clear;
    }
  return bg;
}

// Fills texels of weight 0 from coarser levels (push-pull): sum holds weight x radiance.
void push_pull(std::vector<double>& sum, std::vector<double>& weight, int W, int H) {
  if (W <= 1 && H <= 1) return;
  const int w2 = (W + 1) / 2, h2 = (H + 1) / 2;
  std::vector<double> s2(size_t(w2) * size_t(h2) * 3, 0.0), c2(size_t(w2) * size_t(h2), 0.0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * size_t(W) + size_t(x), j = size_t(y / 2) * size_t(w2) + size_t(x / 2);
      c2[j] += weight[i];
      for (int c = 0; c < 3; ++c) s2[3 * j + size_t(c)] += sum[3 * i + size_t(c)];
    }
  push_pull(s2, c2, w2, h2);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = size_t(y) * size_t(W) + size_t(x), j = size_t(y / 2) * size_t(w2) + size_t(x / 2);
      if (weight[i] > 0.0 || !(c2[j] > 0.0)) continue;
      for (int c = 0; c < 3; ++c) sum[3 * i + size_t(c)] = s2[3 * j + size_t(c)] / c2[j];
      weight[i] = 1.0;
    }
}

double psnr_of(double se, size_t n) { return n ? -10.0 * std::log10(std::max(se / double(3 * n), 1e-12)) : 0.0; }

// What pass 1 keeps of a photo's render for pass 2 (each photo is rendered once):
// its coverage, and a sample of the object's pixels for the report's PSNR (the
// splat's display colour and the photo as stored, every `stride`-th pixel).
struct RenderedView {
  Image opacity;
  std::vector<std::array<float, 6>> samples;
};
constexpr size_t kReportSamples = size_t(1) << 16;  // pixels a photo's report samples at most

// Pass 1 of analyse_capture: each photo's coverage and gains against the splat, the
// subject, whether EXIF exposure applies, and the photos' consensus colour gain.
std::vector<RenderedView> measure_photometry(const SceneAccel& accel, const Dataset& data, const CaptureAnalysisSettings& s,
                                             const CaptureProgress& progress, CaptureAnalysis& a) {
  std::vector<RenderedView> rendered(data.size());
  for (size_t v = 0; v < data.size(); ++v) {
    const SplatImage fwd = render_splat(accel, data.views[v].camera, Vec3(0.0f));
    const auto photo = data.target(v);
    ViewPhotometry p = photometry(fwd, *photo, data.views[v].exposure);
    p.name = data.views[v].camera.name;
    p.exposure = data.views[v].exposure;
    a.exif_present = a.exif_present || p.exposure != 1.0;
    a.views.push_back(p);
    RenderedView& r = rendered[v];
    r.opacity = fwd.opacity;
    const size_t n = r.opacity.pixels.size(), stride = std::max<size_t>(1, n / kReportSamples);
    for (size_t i = 0; i < n; i += stride) {
      const float o = r.opacity.pixels[i];
      if (!(o > 0.5f)) continue;
      std::array<float, 6> e{};
      for (int c = 0; c < 3; ++c) {
        e[size_t(c)] = std::clamp(fwd.colour.pixels[3 * i + size_t(c)] / o, 0.0f, 1.0f);
        e[3 + size_t(c)] = photo->rgb.pixels[3 * i + size_t(c)];
      }
      r.samples.push_back(e);
    }
    if (progress) progress(v + 1, data.size());
  }
  std::vector<double> covered;
  for (const ViewPhotometry& p : a.views) covered.push_back(p.covered);
  a.median_covered = median_of(covered);
  a.subject = s.subject != "auto" ? s.subject : a.median_covered < s.object_coverage ? "object" : "scene";
  // EXIF: applied where it makes the photos agree better with one radiance field.
  std::vector<double> raw, exif;
  for (const ViewPhotometry& p : a.views) {
    if (!(p.gain[0] > 0.0)) continue;
    const double m = (std::log(p.gain[0]) + std::log(p.gain[1]) + std::log(p.gain[2])) / 3.0;
    raw.push_back(m);
    exif.push_back(m - std::log(p.exposure));
  }
  a.spread_raw = std_of(raw);
  a.spread_exif = std_of(exif);
  a.exif_applied = s.exif == "on" || (s.exif == "auto" && a.exif_present && a.spread_exif < a.spread_raw);
  // The consensus (median over photos) of the gains as applied.
  for (int c = 0; c < 3; ++c) {
    std::vector<double> g;
    for (const ViewPhotometry& p : a.views)
      if (p.gain[0] > 0.0) g.push_back(p.gain[size_t(c)] / (a.exif_applied ? p.exposure : 1.0));
    a.colour_gain[size_t(c)] = g.empty() ? 1.0 : median_of(g);
  }
  return rendered;
}

// The end of analyse_capture for an object: the seen share of the sphere, the fine map of what
// the photos saw (`seen`) and the coarse background filled by push-pull (`background`).
void background_maps(const CaptureAnalysisSettings& s, std::vector<double>& sum, std::vector<double>& weight,
                     const std::vector<double>& fsum, const std::vector<double>& fweight, int fine_w,
                     CaptureAnalysis& a) {
  // The seen share of the sphere: texels weighted by their solid angle (sin theta).
  double seen = 0.0, total = 0.0;
  for (int y = 0; y < s.env_height; ++y) {
    const double w = std::sin(3.14159265358979 * (double(y) + 0.5) / double(s.env_height));
    for (int x = 0; x < s.env_width; ++x) {
      total += w;
      seen += weight[size_t(y) * size_t(s.env_width) + size_t(x)] > 0.0 ? w : 0.0;
    }
  }
  a.background_seen = total > 0.0 ? seen / total : 0.0;
  // The 4th channel says which texels were seen ("seen", not "A": no reader treats it as coverage).
  a.seen = Image(fine_w, fine_w / 2, {"R", "G", "B", "seen"});
  for (size_t t = 0; t < fweight.size(); ++t) {
    if (!(fweight[t] > 0.0)) continue;
    for (int c = 0; c < 3; ++c) a.seen.pixels[4 * t + size_t(c)] = float(fsum[3 * t + size_t(c)] / fweight[t]);
    a.seen.pixels[4 * t + 3] = 1.0f;
  }
  const std::vector<double> seen_weight = weight;
  push_pull(sum, weight, s.env_width, s.env_height);
  a.background = Image(s.env_width, s.env_height, {"R", "G", "B", "seen"});
  for (size_t t = 0; t < weight.size(); ++t) {
    for (int c = 0; c < 3; ++c)
      a.background.pixels[4 * t + size_t(c)] = weight[t] > 0.0 ? float(sum[3 * t + size_t(c)] / weight[t]) : 0.5f;
    a.background.pixels[4 * t + 3] = seen_weight[t] >= kSeenPixels ? 1.0f : 0.0f;
  }
}

}  // namespace

CaptureAnalysis analyse_capture(const GaussianField& field, const Dataset& data, const CaptureAnalysisSettings& s,
                                const CaptureProgress& progress) {
  if (data.size() == 0) throw Error(data.root, "capture analysis: no photos");
  CaptureAnalysis a;
  SceneAccel accel(field, {}, AccelSettings{});
  // Pass 1: the renders; coverage and gains per photo, the subject, EXIF, the consensus gain.
  std::vector<RenderedView> rendered = measure_photometry(accel, data, s, progress, a);
  // Pass 2: masks, the splat against the calibrated photos, the background by direction.
  const Environment grid = Environment::constant(Vec3(1.0f), s.env_width, s.env_height);
  // The fine map: about two photo pixels a texel.
  const Camera& cam0 = data.views[0].camera;
  int fine_w = s.detail_width;
  if (fine_w <= 0) {
    fine_w = 512;
    const double px_deg = double(cam0.fov_x) * 57.29578 / double(std::max(1, cam0.width));
    while (fine_w < 2048 && 360.0 / double(fine_w) > 2.0 * px_deg) fine_w *= 2;
  }
  const Environment fine = Environment::constant(Vec3(1.0f), fine_w, fine_w / 2);
  std::vector<double> fsum(size_t(fine_w) * size_t(fine_w / 2) * 3, 0.0), fweight(fsum.size() / 3, 0.0);
  std::vector<double> sum(size_t(s.env_width) * size_t(s.env_height) * 3, 0.0), weight(sum.size() / 3, 0.0);
  double se_splat = 0.0, se_graded = 0.0;
  size_t n_object = 0;
  const bool object = a.subject == "object";
  for (size_t v = 0; v < data.size(); ++v) {
    const ViewPhotometry& p = a.views[v];
    std::array<double, 3> k{};  // the photo as the inversion sees it = stored / k
    for (int c = 0; c < 3; ++c) {
      const double own = p.gain[0] > 0.0 && s.view_gains ? p.gain[size_t(c)] / (a.exif_applied ? p.exposure : 1.0) /
                                                               a.colour_gain[size_t(c)]
                                                         : 1.0;
      k[size_t(c)] = (a.exif_applied ? p.exposure : 1.0) * own;
    }
    // The report: the splat (as is, and times the consensus gain) against the calibrated photo.
    for (const std::array<float, 6>& e : rendered[v].samples) {
      n_object++;
      for (int c = 0; c < 3; ++c) {
        const double lin = double(e[3 + size_t(c)]) * data.views[v].exposure / k[size_t(c)];
        const float sd = e[size_t(c)];
        const double t = linear_to_srgb(float(std::clamp(lin, 0.0, 1.0)));
        const double g = linear_to_srgb(float(std::clamp(srgb_to_linear(sd) * a.colour_gain[size_t(c)], 0.0, 1.0)));
        se_splat += (sd - t) * (sd - t);
        se_graded += (g - t) * (g - t);
      }
    }
    const Image O = std::move(rendered[v].opacity);
    rendered[v] = RenderedView();
    if (!object) continue;
    const auto photo = data.target(v);
    const std::vector<uint8_t> bg = background_pixels(O);
    const Camera& cam = data.views[v].camera;
    for (int y = 0; y < O.height; ++y)
      for (int x = 0; x < O.width; ++x) {
        const size_t i = size_t(y) * size_t(O.width) + size_t(x);
        if (!bg[i]) continue;
        const Vec3 d = cam.generate_ray(float(x) + 0.5f, float(y) + 0.5f).d;
        const size_t tx = size_t(grid.texel_index(d)), fx = size_t(fine.texel_index(d));
        weight[tx] += 1.0;
        fweight[fx] += 1.0;
        for (int c = 0; c < 3; ++c) {
          const double lin = double(photo->rgb.pixels[3 * i + size_t(c)]) * data.views[v].exposure / k[size_t(c)];
          sum[3 * tx + size_t(c)] += lin, fsum[3 * fx + size_t(c)] += lin;
        }
      }
    Image m(O.width, O.height, {"Y"});
    for (size_t i = 0; i < m.pixels.size(); ++i) m.pixels[i] = std::clamp(O.pixels[i], 0.0f, 1.0f);
    a.masks.push_back(std::move(m));
  }
  a.psnr_splat = psnr_of(se_splat, n_object);
  a.psnr_graded = psnr_of(se_graded, n_object);
  if (object) background_maps(s, sum, weight, fsum, fweight, fine_w, a);  // (sum, weight: filled in place)
  return a;
}

CaptureCalibration write_capture_analysis(const CaptureAnalysis& a, const Dataset& data, const CaptureAnalysisSettings& s,
                                          const std::string& out_dir) {
  using ojson = nlohmann::ordered_json;
  fs::create_directories(out_dir);
  CaptureCalibration c;
  c.subject = a.subject;
  c.exif_exposure = a.exif_applied;
  if (!a.masks.empty()) {
    c.masks_dir = (fs::path(out_dir) / "masks").string();
    fs::create_directories(c.masks_dir);
    for (size_t v = 0; v < a.masks.size(); ++v)
      write_image((fs::path(c.masks_dir) / (data.views[v].camera.name + ".png")).string(), a.masks[v], Encoding::Data);
  }
  if (a.background.width > 0) write_image((fs::path(out_dir) / "background_env.exr").string(), a.background);
  if (a.seen.width > 0) write_image((fs::path(out_dir) / "background_seen.exr").string(), a.seen);
  ojson views = ojson::object();
  for (const ViewPhotometry& p : a.views) {
    std::array<float, 3> g{1.0f, 1.0f, 1.0f};
    if (p.gain[0] > 0.0 && s.view_gains)
      for (int k = 0; k < 3; ++k)
        g[size_t(k)] = float(p.gain[size_t(k)] / (a.exif_applied ? p.exposure : 1.0) / a.colour_gain[size_t(k)]);
    c.gain[p.name] = g;
    views[p.name] = {{"covered", p.covered}, {"exif_exposure", p.exposure}, {"gain", {g[0], g[1], g[2]}}};
  }
  ojson rec = {{"subject", a.subject},
               {"median_covered", a.median_covered},
               {"exif", {{"present", a.exif_present}, {"applied", a.exif_applied},
                         {"spread_without", a.spread_raw}, {"spread_with", a.spread_exif}}},
               {"colour_gain_photos_over_splat", {a.colour_gain[0], a.colour_gain[1], a.colour_gain[2]}},
               {"splat_psnr_on_object", a.psnr_splat},
               {"splat_psnr_on_object_graded", a.psnr_graded},
               {"per_photo_gains", s.view_gains},
               {"background_seen", a.background_seen}};
  c.record_json = rec.dump();
  write_capture_calibration((fs::path(out_dir) / "calibration.json").string(), c);
  return c;
}

std::vector<std::string> capture_analysis_lines(const CaptureAnalysis& a) {
  std::vector<std::string> lines;
  char buf[512];
  std::snprintf(buf, sizeof buf, "capture: %s (the splat covers %.0f %% of the median photo)%s",
                a.subject == "object" ? "an object against a background" : "a scene", 100.0 * a.median_covered,
                a.subject == "object" ? ": its coverage masks the photos, the rest is the environment seen directly" : "");
  lines.push_back(buf);
  if (a.exif_present) {
    std::snprintf(buf, sizeof buf,
                  "capture: EXIF exposure %s (the photos' brightness against the splat varies by %.3f in log with it, "
                  "%.3f without)",
                  a.exif_applied ? "applied" : "not applied", a.spread_exif, a.spread_raw);
    lines.push_back(buf);
  }
  std::snprintf(buf, sizeof buf,
                "capture: the splat's colours differ from the photos by x(%.2f, %.2f, %.2f) (photos / splat, linear; "
                "%.1f dB on the object's pixels as is, %.1f dB with that gain): the photos are the targets",
                a.colour_gain[0], a.colour_gain[1], a.colour_gain[2], a.psnr_splat, a.psnr_graded);
  lines.push_back(buf);
  if (a.background.width > 0) {
    std::snprintf(buf, sizeof buf, "capture: the background seen directly covers %.0f %% of the environment: its start",
                  100.0 * a.background_seen);
    lines.push_back(buf);
  }
  return lines;
}

}  // namespace ptir
