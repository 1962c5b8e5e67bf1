// The known map's level on masked photos by short inversions (env_align.h, mode search).
//
// Under a single diffuse bounce the level of a masked object's photos is albedo x light:
// no forward render tells the two apart. What does not scale with the albedo does: a
// dielectric's highlight, the bounce light (albedo^2) and the albedo's bound (<= 1). A
// forward fit with the start materials reads that evidence through the wrong roughness
// (docs/known_light.md: biased x2); an inversion fits the roughness first. So each
// candidate level gets a short inversion from the same start (the run's schedule
// compressed into its iterations, the same views and random numbers), scored by its
// image loss over its last third; the level is the parabola's vertex (log2) through the
// best candidate and its neighbours. Then the state goes back to the start and the full
// run learns at that level.
#include <chrono>
#include <cmath>

#include "ptir/lights/environment.h"
#include "ptir/optim/optimizer.h"

namespace ptir {

void Optimizer::search_known_level() {
  Environment* env = scene_->environment.as<Environment>();
  if (!env) return;
  const auto t0 = std::chrono::steady_clock::now();
  const EnvAlignSettings& s = settings_.env_align;
  // The start: parameters, optimiser moments, normals, the aligned map at the mean-albedo level.
  const Parameters params0 = params_;
  const std::vector<Adam> adam0 = adam_;
  const std::vector<Vec3> normals0 = scene_->gaussians->normal;
  const std::vector<float> texels0 = env->texels();
  const int run_iterations = settings_.iterations;
  const int n = std::max(s.level_min_iterations, int(std::lround(s.level_iterations_share * run_iterations)));
  auto start_at = [&](double log2_factor) {
    params_ = params0;
    adam_ = adam0;
    scene_->gaussians->normal = normals0;
    iteration_ = 0;
    log_.clear();
    const float f = float(std::exp2(log2_factor));
    for (size_t i = 0; i < texels0.size(); ++i) env->texels()[i] = texels0[i] * f;
    env->rebuild_sampling();
    if (ParameterGroup* g = params_.find(ParamKind::Environment)) env->get_raw(g->raw.data());  // a learnt map starts there
    apply();
  };
  // One candidate: its short inversion's mean image loss over the last third.
  std::vector<std::pair<double, double>> scored;  // (log2 factor, loss)
  auto score = [&](double t) {
    for (const auto& c : scored)
      if (c.first == t) return c.second;
    start_at(t);
    settings_.iterations = n;
    double sum = 0;
    int count = 0;
    for (int i = 0; i < n; ++i) {
      const IterationLog l = step();
      if (i >= n - std::max(1, n / 3)) sum += l.image, ++count;
    }
    scored.push_back({t, sum / count});
    return sum / count;
  };
  // Three candidates level_step apart; while the lowest is at an end, one more beyond it.
  const double h = s.level_step;
  double lo = -h, hi = h;
  score(0.0), score(lo), score(hi);
  auto best_t = [&] {
    std::pair<double, double> b = scored.front();
    for (const auto& c : scored)
      if (c.second < b.second) b = c;
    return b.first;
  };
  for (double b = best_t(); (b == lo || b == hi) && std::abs(b) + h <= s.level_max_log2 + 1e-9; b = best_t()) {
    if (b == lo) score(lo -= h);
    else score(hi += h);
  }
  const double b = best_t();
  std::vector<std::pair<double, double>> around;  // the best and its neighbours, relative to it
  for (const auto& c : scored)
    if (std::abs(c.first - b) <= h + 1e-9) around.push_back({c.first - b, c.second});
  const double v = around.size() == 3 ? parabola_vertex(around, h) : std::nan("");
  const double chosen = b + (std::isnan(v) ? 0.0 : v);
  // Back to the start, the map at the chosen level, for the full run.
  settings_.iterations = run_iterations;
  start_at(chosen);
  const double f = std::exp2(chosen);
  env_align_.scale = env_align_.scale * float(f);
  env_align_.level_factor = f;
  env_align_.level_iterations = n;
  for (const auto& c : scored) env_align_.level_candidates.push_back({std::exp2(c.first), c.second});
  env_align_.level_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace ptir
