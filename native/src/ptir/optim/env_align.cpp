// The known map's alignment to the photos (env_align.h): yaw search, then scale.
#include "ptir/optim/env_align.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>

#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/lights/environment.h"
#include "ptir/optim/view_pyramid.h"
#include "ptir/render/render_path.h"

namespace ptir {

namespace {

using ojson = nlohmann::ordered_json;
constexpr float kCovered = 0.99f;  // a pixel of the object: photo alpha and render coverage at least this
constexpr float kMissed = 0.01f;   // a pixel of the background: render coverage at most this

// Per-channel sums of one pixel set: photo P, render R.
struct ChannelSums {
  std::array<double, 3> pr{0, 0, 0}, rr{0, 0, 0}, pp{0, 0, 0};
  size_t pixels = 0;
  void add(const float* p, const float* r) {
    for (int c = 0; c < 3; ++c) {
      pr[c] += double(p[c]) * r[c];
      rr[c] += double(r[c]) * r[c];
      pp[c] += double(p[c]) * p[c];
    }
    ++pixels;
  }
  // The share of the photos' energy the best per-channel scale of the render leaves.
  double residual() const {
    double left = 0, total = 0;
    for (int c = 0; c < 3; ++c) {
      total += pp[c];
      left += rr[c] > 0 ? pp[c] - pr[c] * pr[c] / rr[c] : pp[c];
    }
    return total > 0 ? std::max(0.0, left) / total : 0.0;
  }
  Vec3 level() const {  // sum P R / sum R^2 per channel (0 where the render is black)
    Vec3 l(0.0f);
    for (int c = 0; c < 3; ++c) l[c] = rr[c] > 0 ? float(pr[c] / rr[c]) : 0.0f;
    return l;
  }
};

// The scored views: reduced photos and cameras, fixed for every candidate.
struct ScoredView {
  Camera camera;
  TrainingImage photo;
};

std::vector<ScoredView> scored_views(const Dataset& data, const EnvAlignSettings& s) {
  const size_t n = data.size(), k = std::min(n, size_t(std::max(1, s.views)));
  std::vector<ScoredView> out;
  for (size_t i = 0; i < k; ++i) {
    const size_t v = i * n / k;  // spread over the set
    const int f = pyramid_factor(data.width, data.height, s.max_pixels);
    out.push_back({reduce_camera(data.views[v].camera, f), reduce_training_image(*data.target(v), f)});
  }
  return out;
}

// The object's pixels fall into chromaticity bins of the photo: within one, the albedo is
// about one colour (a shading change keeps a pixel's chromaticity under a white-ish light),
// so each bin's own per-channel scale takes the albedo out and what is left is the light.
constexpr int kChromaBins = 8;  // per axis of (r, g) / (r + g + b)

int chroma_bin(const float* p) {
  const float sum = p[0] + p[1] + p[2];
  if (!(sum > 1e-6f)) return 0;
  auto cell = [](float c) { return std::min(kChromaBins - 1, std::max(0, int(c * kChromaBins))); };
  return cell(p[0] / sum) * kChromaBins + cell(p[1] / sum);
}

struct CandidateScore {
  double score = 0;
  ChannelSums object, background;                 // the level: one scale per channel over all
  std::vector<ChannelSums> bins = std::vector<ChannelSums>(kChromaBins * kChromaBins);
  // The photos' energy that the bins' own scales leave unexplained, over the object's energy.
  double binned_residual() const {
    double left = 0, total = 0;
    for (const ChannelSums& b : bins)
      for (int c = 0; c < 3; ++c) {
        total += b.pp[c];
        left += b.rr[c] > 0 ? b.pp[c] - b.pr[c] * b.pr[c] / b.rr[c] : b.pp[c];
      }
    return total > 0 ? std::max(0.0, left) / total : 0.0;
  }
};

// Renders the views under the environment scene holds now and scores them.
CandidateScore score_views(const PathTracer& tracer, const std::vector<ScoredView>& views, const IntegratorSettings& is) {
  CandidateScore c;
  for (const ScoredView& v : views) {
    const Image r = render_path(tracer, v.camera, is, {}, nullptr, nullptr, v.photo.has_alpha);
    const size_t px = size_t(r.width) * size_t(r.height);
    for (size_t p = 0; p < px; ++p) {
      const float* rp = &r.pixels[4 * p];
      const float* pp = &v.photo.rgb.pixels[3 * p];
      const float a = v.photo.has_alpha ? v.photo.alpha.pixels[p] : 1.0f;
      if (a >= kCovered && rp[3] >= kCovered) {
        // The render's RGB is premultiplied on a transparent film: straight where covered.
        const float inv = v.photo.has_alpha ? 1.0f / rp[3] : 1.0f;
        const float straight[3] = {rp[0] * inv, rp[1] * inv, rp[2] * inv};
        c.object.add(pp, straight);
        c.bins[size_t(chroma_bin(pp))].add(pp, straight);
      } else if (!v.photo.has_alpha && rp[3] <= kMissed) {
        c.background.add(pp, rp);  // the photo sees the map itself there
      }
    }
  }
  c.score = c.binned_residual() + (c.background.pixels > 0 ? c.background.residual() : 0.0);
  return c;
}

double wrap_degrees(double d) {
  d = std::fmod(d, 360.0);
  return d < 0 ? d + 360.0 : d;
}


// The mean luminance of the splats' albedo the renders used (the materials' start).
double start_albedo_luminance(const Scene& scene) {
  if (!scene.gaussians || scene.gaussians->albedo.empty()) return 0.0;
  double sum = 0;
  for (const Vec3& a : scene.gaussians->albedo) sum += luminance(a);
  return sum / double(scene.gaussians->albedo.size());
}

}  // namespace

double parabola_vertex(const std::vector<std::pair<double, double>>& pts, double limit) {
  double m[3][4] = {};  // normal equations of score = a + b t + c t^2
  for (const auto& p : pts) {
    const double t[3] = {1.0, p.first, p.first * p.first};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m[i][j] += t[i] * t[j];
      m[i][3] += t[i] * p.second;
    }
  }
  for (int i = 0; i < 3; ++i) {  // Gauss-Jordan; the t's are distinct, so the pivots are not 0
    if (m[i][i] == 0.0) return std::nan("");
    for (int k = 0; k < 3; ++k) {
      if (k == i) continue;
      const double f = m[k][i] / m[i][i];
      for (int j = i; j < 4; ++j) m[k][j] -= f * m[i][j];
    }
  }
  const double b = m[1][3] / m[1][1], c = m[2][3] / m[2][2];
  if (!(c > 0.0)) return std::nan("");
  const double v = -b / (2.0 * c);
  return std::abs(v) <= limit ? v : std::nan("");
}

namespace {

// The yaw search: every coarse step, then every degree within one step of the
// best, then the parabola of the basin's walls. Fills r.candidates.
struct YawSearch {
  Environment& env;
  const std::vector<float>& given;
  const PathTracer& tracer;
  const std::vector<ScoredView>& views;
  const IntegratorSettings& is;
  std::map<long, CandidateScore> scored;  // by hundredths of a degree
  EnvAlignResult& r;

  const CandidateScore& at(double deg) {
    const long key = std::lround(wrap_degrees(deg) * 100.0) % 36000;
    auto it = scored.find(key);
    if (it != scored.end()) return it->second;
    env.texels() = rotate_latlong_yaw(given, env.width(), env.height(), double(key) / 100.0 * kPi / 180.0);
    env.rebuild_sampling();
    CandidateScore c = score_views(tracer, views, is);
    r.candidates.push_back({double(key) / 100.0, c.score});
    return scored.emplace(key, std::move(c)).first->second;
  }

  double run(float coarse_step) {
    const int step = std::max(1, int(std::lround(coarse_step)));
    int centre = 0;
    for (int d = 0; d < 360; d += step)
      if (at(d).score < at(centre).score) centre = d;
    int best = centre;
    for (int t = -step + 1; t < step; ++t)
      if (at(centre + t).score < at(best).score) best = int(wrap_degrees(centre + t));
    // The basin's bottom is flat and its lowest degree jitters (noise, and a few degrees
    // of bias the start materials leave on a soft light: docs/known_light.md); its walls
    // say where its middle is. So the yaw is the vertex of the parabola through 7 points
    // a coarse step apart around the lowest degree (within one step of it).
    std::vector<std::pair<double, double>> wide;
    for (int k = -3; k <= 3; ++k) wide.push_back({double(k * step), at(best + k * step).score});
    const double v = parabola_vertex(wide, step);
    const double yaw = std::isfinite(v) ? wrap_degrees(std::round((best + v) * 10.0) / 10.0) : double(best);
    at(yaw);
    return yaw;
  }
};

}  // namespace

const char* env_align_mode_name(EnvAlignMode m) {
  switch (m) {
    case EnvAlignMode::Off: return "off";
    case EnvAlignMode::Yaw: return "yaw";
    case EnvAlignMode::Auto: return "auto";
    case EnvAlignMode::Full: return "full";
    case EnvAlignMode::Search: return "search";
  }
  return "?";
}

EnvAlignMode parse_env_align_mode(const std::string& name, const std::string& what) {
  for (EnvAlignMode m : {EnvAlignMode::Off, EnvAlignMode::Yaw, EnvAlignMode::Auto, EnvAlignMode::Full, EnvAlignMode::Search})
    if (name == env_align_mode_name(m)) return m;
  throw Error(what + " must be 'auto', 'off', 'yaw', 'full' or 'search', got '" + name + "'");
}

std::vector<float> rotate_latlong_yaw(const std::vector<float>& texels, int width, int height, double yaw_rad) {
  if (texels.size() != size_t(width) * size_t(height) * 3) throw Error("rotate_latlong_yaw: texel count differs from the size");
  // Looked up with rotation_z = yaw, a direction at u reads the map at u - yaw / (2 pi)
  // (lights/environment.h): the baked map holds that. In texel units: a shift of
  // -yaw / (2 pi) * W, read by linear interpolation between the two nearest texels.
  double shift = -yaw_rad / (2.0 * kPi) * double(width);
  shift -= std::floor(shift / double(width)) * double(width);  // in [0, W)
  const int whole = int(std::floor(shift));
  const float frac = float(shift - double(whole));
  std::vector<float> out(texels.size());
  for (int y = 0; y < height; ++y) {
    const float* row = &texels[size_t(y) * size_t(width) * 3];
    float* dst = &out[size_t(y) * size_t(width) * 3];
    for (int x = 0; x < width; ++x) {
      // Texel x of the result reads the input at x + shift (u grows with x).
      const int a = (x + whole) % width, b = (a + 1) % width;
      for (int c = 0; c < 3; ++c)
        dst[3 * x + c] = frac == 0.0f ? row[3 * a + c] : (1.0f - frac) * row[3 * a + c] + frac * row[3 * b + c];
    }
  }
  return out;
}

EnvAlignResult align_environment(Scene& scene, const PathTracer& tracer, const Dataset& data,
                                 const IntegratorSettings& base, const EnvAlignSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  EnvAlignResult r;
  r.mode = s.mode;
  if (s.mode == EnvAlignMode::Off) return r;
  Environment* env = scene.environment.as<Environment>();
  if (!env) throw Error("aligning a known environment needs the lat-long model (--env latlong)");
  const std::vector<float> given = env->texels();
  const std::vector<ScoredView> views = scored_views(data, s);
  IntegratorSettings is = base;
  is.spp = std::max(1, s.spp);
  is.max_bounces = std::min(base.max_bounces, std::max(0, s.bounces));
  YawSearch search{*env, given, tracer, views, is, {}, r};
  double best = search.run(s.coarse_step_deg);
  const CandidateScore& zero = search.at(0);
  if (best != 0 && !(search.at(best).score < zero.score * (1.0 - double(s.keep_margin)))) best = 0;
  const CandidateScore& won = search.at(best);
  r.yaw_deg = best;
  r.score = won.score;
  r.score_unaligned = zero.score;
  r.views = int(views.size());
  r.pixels = int(won.object.pixels);
  r.photo_level = won.object.level();
  r.background_level = won.background.level();
  env->texels() = rotate_latlong_yaw(given, env->width(), env->height(), best * kPi / 180.0);
  // The level: the background's where seen (the map itself), else the mean albedo for "full".
  const bool background = won.background.pixels > 0 && r.background_level.x > 0 && r.background_level.y > 0 &&
                          r.background_level.z > 0;
  if (s.mode != EnvAlignMode::Yaw && background) {
    r.scale = r.background_level;
    r.scale_from = "background";
  } else if ((s.mode == EnvAlignMode::Full || s.mode == EnvAlignMode::Search ||
              (s.mode == EnvAlignMode::Auto && s.map_fixed)) &&
             luminance(r.photo_level) > 0) {
    // The renders' albedo is the materials' start: under the map, the object's mean albedo
    // is about their mean times the level; one exposure for all channels (the map's colour
    // kept) makes its luminance reference_albedo. "search" starts there (the optimiser's
    // short inversions then pick the level).
    r.scale = Vec3(float(luminance(r.photo_level) * start_albedo_luminance(scene) / s.reference_albedo));
    r.scale_from = s.mode == EnvAlignMode::Full ? "mean albedo" : "short inversions";
  }
  for (size_t i = 0; i < env->texels().size(); ++i)
    env->texels()[i] = std::max(env->texels()[i] * r.scale[int(i % 3)], 1e-6f);
  env->rebuild_sampling();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string EnvAlignResult::json() const {
  auto vec = [](Vec3 v) { return ojson::array({v.x, v.y, v.z}); };
  // Exposure: the scale's luminance (Rec. 709 weights); white balance: the scale over it.
  const double exposure = luminance(scale);
  ojson j = ojson::object();
  j["mode"] = env_align_mode_name(mode);
  j["yaw_deg"] = yaw_deg;
  j["scale"] = vec(scale);
  j["exposure"] = exposure;
  j["white_balance"] = vec(exposure > 0 ? scale * float(1.0 / exposure) : scale);
  j["scale_from"] = scale_from;
  if (scale_from == "short inversions") {
    ojson lc = ojson::array();
    for (const auto& fl : level_candidates) lc.push_back({fl.first, fl.second});
    j["level_candidates"] = lc;
    j["level_factor"] = level_factor;
    j["level_iterations"] = level_iterations;
    j["level_seconds"] = level_seconds;
  }
  j["photo_level"] = vec(photo_level);
  j["background_level"] = vec(background_level);
  j["score"] = score;
  j["score_unaligned"] = score_unaligned;
  j["views"] = views;
  j["pixels"] = pixels;
  j["seconds"] = seconds;
  ojson c = ojson::array();
  for (const auto& yc : candidates) c.push_back({yc.first, yc.second});
  j["candidates"] = c;
  return j.dump();
}

std::string EnvAlignResult::summary() const {
  char line[320];
  const double exposure = luminance(scale);
  std::snprintf(line, sizeof line,
                "env-align %s: yaw %.0f deg, scale %.3g %.3g %.3g (exposure %.3g, from %s), score %.4f (unaligned %.4f), "
                "%zu candidates, %d views, %.1f s",
                env_align_mode_name(mode), yaw_deg, scale.x, scale.y, scale.z, exposure, scale_from.c_str(), score,
                score_unaligned, candidates.size(), views, seconds);
  return line;
}

}  // namespace ptir
