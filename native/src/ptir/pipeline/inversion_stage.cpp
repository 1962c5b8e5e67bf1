// The inversion stage of the optimise pipeline (pipeline_run.h): materials and
// the environment on the stages' splats (docs/method.md §6), with its progress,
// budget pacing, checkpoints, Ctrl-C and data-parallel stop lines.
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "ptir/core/error.h"
#include "ptir/optim/budget_plan.h"
#include "ptir/optim/checkpoint.h"
#include "ptir/optim/iteration_estimate.h"
#include "ptir/optim/optimizer.h"
#include "ptir/optim/optimizer_setup.h"
#include "ptir/pipeline/brdf_choice.h"
#include "ptir/pipeline/capture_stage.h"
#include "ptir/pipeline/job_stop.h"
#include "ptir/pipeline/pipeline_run.h"
#include "ptir/pipeline/run_control.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene.h"

namespace ptir::pipeline {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The optimiser for the run's options (inputs loaded; resumed when asked).
std::unique_ptr<Optimizer> make_optimizer(const PipelineRun& o, std::shared_ptr<const Dataset>* data) {
  OptimizeOptions opt = o.opt;
  if (o.inversion_fine_share > 0.0) opt.fine_fraction = float(o.inversion_fine_share);  // the plan it resumes
  char extra = 0;
  if (std::sscanf(o.env_size.c_str(), "%dx%d%c", &opt.env_width, &opt.env_height, &extra) != 2 || opt.env_width < 1 ||
      opt.env_height < 1)
    throw Error("--env-size must be WIDTHxHEIGHT (e.g. 128x64), got '" + o.env_size + "'");
  OptimizerSettings s = optimizer_settings(opt, cli_option_name);

  DatasetOptions dopt;
  dopt.split = o.split;
  dopt.prior_dir = o.prior;
  apply_capture_options(o.capture, dopt);
  *data = load_dataset(o.dataset, dopt);
  if (!o.estimate) (*data)->check_images();  // every photo decodes and fits its camera, before any iteration
  // The filter the views were rendered with (dataset.json), else Blender's default; the options override it.
  s.integrator.filter = dataset_pixel_filter(**data);
  apply_filter_options(o.filter, o.given.count("--pixel-filter") > 0, o.given.count("--filter-width") > 0,
                       s.integrator.filter);
  auto note = [&](const std::string& line) {
    if (!o.quiet) std::fprintf(stderr, "note: %s\n", line.c_str());
  };
  Scene scene = prepare_optimizer_scene(o.scene, std::make_shared<GaussianField>(load_gaussians(o.gaussians)), s,
                                        cli_option_name, note);
  // The model: --brdf; else a resumed run's own (its checkpoint's: "principled" = v1);
  // else the scene file's, the dataset's recorded one, or principled-v2.
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  s.integrator.brdf = resolve_bsdf_model(scene.brdf_from_file, s.integrator.brdf, (*data)->brdf);
  if (o.resume && o.brdf.empty() && std::filesystem::exists(ckpt))
    for (const auto& kv : read_checkpoint(ckpt).fingerprint)
      if (kv.first == "brdf" && parse_bsdf_model(kv.second)) s.integrator.brdf = *parse_bsdf_model(kv.second);
  apply_brdf_choice(o.brdf, s.integrator.brdf);
  if (!o.quiet) std::fprintf(stderr, "optimize: surface model %s\n", to_string(s.integrator.brdf));
  auto optimizer = std::make_unique<Optimizer>(std::move(scene), *data, s);
  if (!o.quiet && optimizer->env_alignment().mode != EnvAlignMode::Off)
    std::fprintf(stderr, "optimize: %s\n", optimizer->env_alignment().summary().c_str());
  if (o.resume) {
    std::error_code ec;
    if (!std::filesystem::exists(ckpt, ec)) throw Error(ckpt, "--resume: no checkpoint to continue from");
    optimizer->load_checkpoint(ckpt);
    if (!o.quiet) std::fprintf(stderr, "resumed from %s at iteration %d\n", ckpt.c_str(), optimizer->iteration());
  }
  return optimizer;
}

// The stop line of a data-parallel run (job_stop.h) after `done` iterations, the
// checkpoint holding iteration `saved` (< 0: none yet).
std::string stop_message(const std::string& ckpt, int done, int saved) {
  std::string m = "ptir: the MPI job was stopped after iteration " + std::to_string(done) +
                  " (a rank failed, or the job was cancelled or ran out of time); ";
  if (saved < 0) return m + "no checkpoint was written yet";
  return m + ckpt + " holds iteration " + std::to_string(saved) +
         " or later: continue with --resume (any number of ranks)";
}

// The run's summary lines before the first iteration (the estimate's only with a fixed count).
void print_run_header(const PipelineRun& o, Optimizer& opt, const Dataset& data, const Communicator& comm,
                      const BudgetState& budget) {
  if (!o.quiet)
    std::fprintf(stderr,
                 "optimize: %zu Gaussians, %zu %s views %dx%d%s, %d iterations, %d spp, %d bounces (indirect: %s), loss %s, env %s, "
                 "seed %llu\n",
                 opt.scene().gaussians->size(), data.size(), data.split.c_str(), data.width, data.height,
                 data.has_priors() ? " (with priors)" : "", opt.settings().iterations, opt.settings().integrator.spp, o.opt.bounces, o.opt.indirect.c_str(),
                 o.opt.loss_space.c_str(),
                 o.opt.env.c_str(),
                 (unsigned long long)o.opt.seed);
  if (!o.quiet && comm.size() > 1)
    std::fprintf(stderr, "optimize: %d MPI ranks, each view split in row bands across them\n", comm.size());
  if (!o.quiet && budget.budget_s == 0.0 && opt.iteration() < opt.settings().iterations) {  // measured on a probe window (iteration_estimate.h)
    const IterationEstimate est = estimate_iteration(opt);
    const int left = opt.settings().iterations - opt.iteration();
    char line[512];
    std::snprintf(line, sizeof line, "optimize: estimated %.2f s/iter, %s for %d iterations (probe %d pixels at %d spp: %.2f + %.2f us per "
                 "path sample, primal + replay; regulariser %.2f us per pixel)\n", est.seconds,
                 duration_text(est.seconds * left).c_str(), left, est.probe_pixels, est.probe_spp,
                 1e6 * est.primal_per_sample, 1e6 * est.replay_per_sample, 1e6 * est.regulariser_per_pixel);
    o.progress.estimate(est.seconds, left, line);
  }
}

// A budgeted run's pacing (optimize_budget.h): after each iteration the count is
// re-planned from the measured rate and OUT/budget.json records the time spent.
class BudgetPacing {
 public:
  BudgetPacing(const BudgetState& budget, Clock::time_point t_start, Clock::time_point t0, int start_it)
      : budget_(budget), t_start_(t_start), t0_(t0), last_(t0), start_it_(start_it),
        pacer_(budget.budget_s - budget.spent_s - kOutputReserve) {}

  void after_iteration(Optimizer& opt, const IterationLog& l, const std::string& out) {
    if (budget_.budget_s <= 0.0) return;
    const auto now = Clock::now();
    const double since_start = std::chrono::duration<double>(now - t_start_).count();
    phases_.add(l.level, std::chrono::duration<double>(now - last_).count());
    last_ = now;
    const int total = opt.pyramid_coarse_share() > 0.0
                          ? pacer_.replan(opt.iteration(), since_start, opt.settings().iterations,
                                          phases_.costs(opt.pyramid_coarse_share(),
                                                        budget_.est_coarse_s > 0.0 ? budget_.est_fine_s / budget_.est_coarse_s : 1.0))
                          : pacer_.replan(opt.iteration(), opt.iteration() - start_it_,
                                          std::chrono::duration<double>(now - t0_).count(), since_start,
                                          opt.settings().iterations);
    if (total != opt.settings().iterations) opt.set_iterations(total);
    BudgetState b = budget_;
    b.spent_s += since_start;
    write_budget_state(out, b);
  }

 private:
  BudgetState budget_;
  Clock::time_point t_start_, t0_, last_;
  int start_it_;
  BudgetPacer pacer_;
  PhaseClock phases_;  // the resolution pyramid's two phases, timed apart
};

// The iterations, with their progress, until the count or a stop.
RunResult run_iterations(const PipelineRun& o, Optimizer& opt, const Communicator& comm, const BudgetState& budget) {
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  auto previous = install_sigint();
  const int start_it = opt.iteration();
  const auto t0 = Clock::now();
  RunOptions ro;
  ro.out_dir = comm.rank() == 0 ? o.out : "";
  ro.checkpoint_every = o.checkpoint_every;
  ro.cancel = &g_interrupted;
  int saved = o.resume ? start_it : -1;  // the iteration OUT/checkpoint.bin holds (data-parallel stop line)
  if (comm.size() > 1) {
    ro.cancel = nullptr;  // no rank may stop alone mid-iteration (job_stop.h)
    std::signal(SIGINT, previous);
    install_job_stop_handlers(comm.rank() == 0);
    set_job_stop_message(stop_message(ckpt, start_it, saved));
  }
  BudgetPacing pacing(budget, o.t_start, t0, start_it);
  ro.on_iteration = [&](const IterationLog& l) {
    pacing.after_iteration(opt, l, o.out);
    if (comm.size() > 1) {
      // run_optimizer has saved the checkpoint of the previous iteration by now.
      const int prev = opt.iteration() - 1;
      if (o.checkpoint_every > 0 && prev > start_it && prev % o.checkpoint_every == 0) saved = prev;
      set_job_stop_message(stop_message(ckpt, opt.iteration(), saved));
    }
    const int done = opt.iteration() - start_it;
    const double per = done > 0 ? seconds_since(t0) / done : l.seconds;
    o.progress.optimize_iteration(l, opt.settings().iterations, per * double(opt.settings().iterations - opt.iteration()));
    return true;
  };
  return with_sigint_restored(previous, [&] { return run_optimizer(opt, ro); });
}

}  // namespace

int run_inversion_stage(PipelineRun& o, const Communicator& comm, BudgetState budget) {
  std::shared_ptr<const Dataset> data;
  std::unique_ptr<Optimizer> optimizer = make_optimizer(o, &data);
  Optimizer& opt = *optimizer;
  if (o.estimate) {  // with a budget: the inversion's share of it (a geometry stage would take up to kFitShare)
    const int rc = comm.rank() == 0 ? print_estimate(opt, o.t_start,
                                                     budget.budget_s * (o.fit_iters > 0 && !o.dataset.empty() ? 1.0 - kFitShare : 1.0),
                                                     o.targets_left_s, budget.choose_fine_share)
                                    : 0;
    comm.barrier();  // every rank done with the scratch folder before it goes
    return rc;
  }
  if (budget.budget_s > 0.0) budget = plan_optimizer_budget(opt, budget, o.t_start, o.quiet);
  opt.set_communicator(comm);
  print_run_header(o, opt, *data, comm, budget);
  const RunResult r = run_iterations(o, opt, comm, budget);
  if (o.plan) o.plan->commit();  // the results are the new plan's: it goes in place with them
  if (opt.nonfinite_gradients() > 0 && !o.quiet)
    std::fprintf(stderr, "warning: %zu non-finite gradient entries were dropped\n", opt.nonfinite_gradients());
  const std::string ckpt = (std::filesystem::path(o.out) / "checkpoint.bin").string();
  if (r == RunResult::Cancelled) {
    o.progress.done("optimize", false, opt.iteration(), o.out);
    std::fprintf(stderr, "ptir: interrupted after iteration %d; wrote %s and the outputs in %s (continue with --resume)\n",
                 opt.iteration(), ckpt.c_str(), o.out.c_str());
    return 130;
  }
  if (o.env_detail && comm.rank() == 0) write_env_with_detail(o.out);
  if (!o.quiet)
    std::fprintf(stderr, "wrote %s/gaussians.ply, env.exr, log.csv (%d iterations)\n", o.out.c_str(), opt.iteration());
  o.progress.done("optimize", true, opt.iteration(), o.out);
  return 0;
}

}  // namespace ptir::pipeline
