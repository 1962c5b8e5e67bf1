#include "ptir/optim/iteration_estimate.h"

#include <algorithm>
#include <chrono>

#include "ptir/render/aov_backward.h"
#include "ptir/render/material_maps.h"
#include "ptir/render/render_path.h"

namespace ptir {

namespace {

double seconds_of(const std::chrono::steady_clock::time_point& t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

constexpr int kGrid = 4, kSide = 24;  // a 4 x 4 grid of 24 x 24 windows
constexpr int kRatioSide = 48;         // the replay / primal window

// The side x side window centred at (x, y), moved into the image (the whole image when smaller).
Camera window(const Camera& c, int x, int y, int side) {
  const int w = std::min(side, c.width), h = std::min(side, c.height);
  if (w == c.width && h == c.height) return c;
  return c.crop(std::clamp(x - w / 2, 0, c.width - w), std::clamp(y - h / 2, 0, c.height - h), w, h);
}

}  // namespace

IterationEstimate estimate_iteration(const Optimizer& opt) {
  IterationEstimate e;
  const Dataset& data = opt.dataset();
  if (data.size() == 0) return e;
  const OptimizerSettings& s = opt.settings();
  const Camera& view = data.views.front().camera;
  IntegratorSettings is = s.integrator;
  is.seed = 0x5eed;
  // Warm-up: lazily built tables and first-touch memory are not part of an iteration's cost.
  render_path(opt.tracer(), window(view, view.width / 2, view.height / 2, 8), is);
  is.spp = std::max(1, std::min(s.integrator.spp, 4));
  e.probe_spp = is.spp;
  SceneGradients grads = SceneGradients::zeros_like(opt.scene());
  // Primal cost per sample: over the grid of windows.
  double primal = 0.0, samples = 0.0;
  for (int gy = 0; gy < kGrid; ++gy)
    for (int gx = 0; gx < kGrid; ++gx) {
      const Camera probe = window(view, (2 * gx + 1) * view.width / (2 * kGrid), (2 * gy + 1) * view.height / (2 * kGrid),
                                  kSide);
      auto t0 = std::chrono::steady_clock::now();
      render_path(opt.tracer(), probe, is);
      primal += seconds_of(t0);
      samples += double(probe.width) * probe.height * is.spp;
      e.probe_pixels += probe.width * probe.height;
    }
  e.primal_per_sample = primal / samples;
  // Replay: its cost relative to the primal on one central window, less a replay call's fixed cost
  // (per-chunk gradient buffers sized by the scene, paid once per view), timed on a 1 x 1 window.
  auto timed_pair = [&](const Camera& cam, double* t_primal, double* t_replay) {
    // As the optimiser replays: from each sample's radiance, ray outcomes and walks.
    WalkStore walks(s.sample_cache_bytes);
    ReplayCache cache;
    cache.walks = &walks;
    auto t0 = std::chrono::steady_clock::now();
    render_path(opt.tracer(), cam, is, {}, nullptr, &cache);
    *t_primal = seconds_of(t0);
    Image d(cam.width, cam.height, {"R", "G", "B"});
    std::fill(d.pixels.begin(), d.pixels.end(), 1e-3f);
    t0 = std::chrono::steady_clock::now();
    render_path_backward(opt.tracer(), cam, is, d, grads, {}, &cache);
    *t_replay = seconds_of(t0);
  };
  double p1 = 0.0, r1 = 0.0, pc = 0.0, rc = 0.0;
  timed_pair(window(view, view.width / 2, view.height / 2, 1), &p1, &r1);
  timed_pair(window(view, view.width / 2, view.height / 2, kRatioSide), &pc, &rc);
  e.replay_fixed = r1;
  const double ratio = pc > 0.0 ? std::max(0.5, (rc - r1) / pc) : 1.0;  // replay is never cheaper than half a primal
  e.replay_per_sample = ratio * e.primal_per_sample;
  // The batch of an iteration at reduction factor f: its views and their pixels (a crop when cropping).
  auto batch = [&](int f) {
    const auto [views, crop] = opt.batch_at(f);
    int w = data.width / f, h = data.height / f;
    if (crop > 0) {
      w = std::min(w, crop);
      h = std::min(h, crop);
    }
    return std::make_pair(double(w) * h * views, double(views));
  };
  // The material-map regulariser (when on): its maps and their adjoint from the kept walks, as the
  // optimiser runs them, timed on the central window.
  if (s.lambda_tv > 0.0f || data.has_priors()) {
    const Camera cam = window(view, view.width / 2, view.height / 2, kRatioSide);
    AovSettings as;
    as.interaction = s.integrator.interaction;
    as.spp = 1;
    as.seed = is.seed;
    Image alb, rough, coverage;
    MaterialMapWalks walks;
    auto t0 = std::chrono::steady_clock::now();
    render_material_maps(opt.tracer().accel(), cam, as, {}, &alb, &rough, &coverage, &walks);
    Image d_alb(cam.width, cam.height, {"R", "G", "B"}), d_rough(cam.width, cam.height, {"Y"});
    std::fill(d_alb.pixels.begin(), d_alb.pixels.end(), 1e-3f);
    std::fill(d_rough.pixels.begin(), d_rough.pixels.end(), 1e-3f);
    render_aov_backward(opt.tracer().accel(), cam, as, &d_alb, &d_rough, grads, &walks);
    e.regulariser_per_pixel = seconds_of(t0) / (double(cam.width) * cam.height);
  }
  auto fixed = [&](int f) { return batch(f).first * e.regulariser_per_pixel + batch(f).second * e.replay_fixed; };
  auto seconds = [&](int f) {
    return batch(f).first * double(opt.spp_at(f)) * (e.primal_per_sample + e.replay_per_sample) + fixed(f);
  };
  e.coarse_share = opt.pyramid_coarse_share();
  const int fc = opt.pyramid_coarse_factor();
  e.fine_seconds = seconds(1);
  e.coarse_seconds = e.coarse_share > 0.0 ? seconds(fc) : e.fine_seconds;
  e.coarse_fixed_seconds = e.coarse_share > 0.0 ? fixed(fc) : fixed(1);
  e.fine_fixed_seconds = fixed(1);
  e.coarse_spp = opt.spp_at(e.coarse_share > 0.0 ? fc : 1);
  e.fine_spp = opt.spp_at(1);
  e.fine_views = opt.batch_at(1).first;
  e.fine_patches_auto = opt.auto_views() && opt.batch_at(1).second > 0;
  e.fine_view_pixels = batch(1).first / std::max(1.0, batch(1).second);
  e.train_pixels = double(data.width) * data.height * double(data.size());
  e.fixed_seconds = e.coarse_share * e.coarse_fixed_seconds + (1.0 - e.coarse_share) * e.fine_fixed_seconds;
  e.seconds = e.coarse_share * e.coarse_seconds + (1.0 - e.coarse_share) * e.fine_seconds;
  return e;
}

}  // namespace ptir
