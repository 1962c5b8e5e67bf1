// Optimizer's light solve (light_solve.h): when it runs, and how its node scales
// go into the environment's parameter groups.
#include <cmath>

#include "ptir/core/error.h"
#include "ptir/math/rng.h"
#include "ptir/optim/optimizer.h"

namespace ptir {

namespace {
constexpr uint64_t kTagLightSolve = 0x6c69676874ull;  // "light"
}  // namespace

bool Optimizer::light_solve_due(int it) const {
  for (float f : settings_.light_solve.at)
    if (int(std::floor(double(f) * settings_.iterations)) == it) return true;
  return false;
}

void Optimizer::solve_light(const std::atomic<bool>* cancel) {
  Environment* map = scene_->environment.as<Environment>();
  ParameterGroup* fine = params_.find(ParamKind::Environment);
  if (!map || !fine || !settings_.params.optimize_env) return;  // nothing to solve (SG, constant, fixed light)
  const ParameterGroup* coarse_group = params_.find(ParamKind::EnvironmentCoarse);
  const LightSolveSettings& ls = settings_.light_solve;
  // The nodes: the coarse level's grid, else grid_width x grid_width / 2.
  const LatlongUpsampler grid = coarse_group ? coarse_upsampler(*coarse_group, *scene_)
                                             : LatlongUpsampler(ls.grid_width, std::max(1, ls.grid_width / 2),
                                                                map->width(), map->height());
  LightNormalEquations eq(grid.coarse_width(), grid.coarse_height());
  // Every training view (this rank's share of them), whole, at the solve's spp.
  IntegratorSettings is = settings_.integrator;
  is.spp = std::clamp(ls.spp, 2, SceneAccel::kMaxPacket);
  for (size_t v = 0; v < dataset_->size(); ++v) {
    if (int(v % size_t(comm_->size())) != comm_->rank()) continue;
    std::shared_ptr<const TrainingImage> target = dataset_->target(v);
    is.seed = hash_combine(hash_combine(settings_.seed, kTagLightSolve), hash_combine(uint64_t(iteration_), uint64_t(v)));
    add_light_view(*tracer_, dataset_->views[v].camera, is, target->rgb, target->has_alpha ? &target->alpha : nullptr,
                   settings_.mask_threshold, ExposureGradients::scale(params_, v), settings_.srgb_loss, grid, eq, cancel);
  }
  eq.allreduce(*comm_);
  LightSolveReport report;
  const std::vector<float> s = solve_light_scales(eq, ls, &report);
  light_solves_.push_back({iteration_, report});

  // The new light: texels x the interpolated scales. Its log goes back into the
  // groups with the change in the coarse level (log s at the nodes) and the rest,
  // the fine detail the texels held, in the fine one: raw = fine + up(coarse).
  std::vector<float> texels = map->texels();
  scale_texels(grid, map->width(), map->height(), s, texels);
  if (ParameterGroup* coarse = params_.find(ParamKind::EnvironmentCoarse)) {
    for (size_t k = 0; k < coarse->raw.size(); ++k) coarse->raw[k] += std::log(s[k]);
    std::vector<float> up(texels.size(), 0.0f);
    grid.add_up(coarse->raw.data(), up.data());
    for (size_t i = 0; i < texels.size(); ++i) fine->raw[i] = std::log(std::max(texels[i], 1e-8f)) - up[i];
  } else {
    for (size_t i = 0; i < texels.size(); ++i) fine->raw[i] = std::log(std::max(texels[i], 1e-8f));
  }
  apply();
}

}  // namespace ptir
