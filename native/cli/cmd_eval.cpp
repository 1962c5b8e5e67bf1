// `ptir eval`: renders every test view of a dataset with the recovered materials
// and environment, and scores them against the ground truth (docs/method.md §7;
// src/ptir/eval/evaluate.h has the exact protocol).
//
//   ptir eval --dataset DIR --result OUT [--relight NAME=env.exr ...] [--spp N]
//       [--bounces N] [--aov-spp N] [--split test] [--scene scene.json] [--seed S]
//       [--sheet-views N] [--threads N] [-q]
//
// Writes OUT/eval/test_XXX/{rgba,albedo,roughness,metallic,normal}.exr and
// rgba_NAME.exr, OUT/eval/metrics.json, OUT/eval/metrics.md and the contact
// sheets OUT/eval/sheet_*.png; prints the metric table on stdout. Under MPI
// (`mpirun -np N ptir eval ...`) every render is split across the ranks in row
// bands; rank 0 writes and prints.
#include <tbb/global_control.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "brdf_option.h"
#include "capture_flags.h"
#include "commands.h"
#include "filter_flags.h"
#include "output_guard.h"
#include "ptir/core/error.h"
#include "world.h"
#include "ptir/eval/evaluate.h"

namespace ptir::cli {

namespace {

struct EvalOptions {
  std::string dataset, result, split = "test", scene;
  std::string brdf;  // --brdf (empty: the scene file's, else the dataset's "ptir_brdf", else principled-v2)
  std::vector<std::string> relight;
  int spp = 64, bounces = 4, aov_spp = 16;
  uint64_t seed = 0;
  int sheet_views = 8;
  int threads = 0;
  FilterFlags filter;
  CaptureFlags capture;  // real captures: the same switches as optimize
  bool quiet = false;
  bool force = false;
};

int run_eval(const EvalOptions& options, const CLI::App& cmd) {
  // Data-parallel runs (world.h): renders split across the ranks; rank 0 reports and writes.
  const Communicator& comm = world();
  EvalOptions o = options;
  if (comm.rank() != 0) o.quiet = true;
  std::optional<tbb::global_control> limit;
  if (o.threads < 0) throw Error("--threads must be positive");
  if (o.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(o.threads));
  if (o.spp < 1 || o.aov_spp < 1) throw Error("--spp and --aov-spp must be at least 1");
  if (o.bounces < 0) throw Error("--bounces must be at least 0");
  eval::EvalSettings s;
  s.dataset = o.dataset;
  s.result = o.result;
  s.split = o.split;
  apply_capture_flags(o.capture, s.dataset_options);
  s.scene = o.scene;
  for (const std::string& r : o.relight) s.relight.push_back(eval::parse_relight(r));
  const std::string out = o.result + "/eval";
  Inputs in{{}, {o.dataset, o.result}, {o.scene}, {o.dataset}};
  for (const eval::RelightEnv& r : s.relight) in.files.push_back(r.path);
  guard_outputs(in, {{}, {out}}, o.force);
  std::unique_ptr<io::OutputLock> lock;  // the result's one writer (eval/ is replaced whole at the end)
  if (comm.rank() == 0) {
    lock = lock_output_folder(o.result, "ptir eval");
    remove_stale_outputs({out}, o.quiet, /*with_subfolders=*/true);
  }
  s.comm = &comm;
  s.spp = o.spp;
  s.bounces = o.bounces;
  s.aov_spp = o.aov_spp;
  s.seed = o.seed;
  if (!o.brdf.empty()) {
    BsdfModel m = BsdfModel::PrincipledV1;
    cli::apply_brdf_option(o.brdf, m);
    s.brdf = m;
  }
  s.sheet_views = o.sheet_views;
  {
    // Switches not given keep the dataset's value (or Blender's default).
    PixelFilter f;
    apply_filter_flags(o.filter, cmd, f);
    if (cmd.count("--pixel-filter")) s.filter_type = f.type;
    if (cmd.count("--filter-width")) s.filter_width = f.width;
  }
  if (!o.quiet) s.log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  eval::EvalReport r = eval::evaluate(s);
  if (comm.rank() != 0) return 0;
  std::printf("%s", eval::metrics_markdown(r.metrics).c_str());
  if (!o.quiet)
    std::fprintf(stderr, "wrote %s/metrics.json, metrics.md, %zu contact sheets and the renders (%.1f s)\n",
                 r.out_dir.c_str(), r.metrics["sheets"].size(), r.metrics["seconds"]["total"].get<double>());
  return 0;
}

}  // namespace

Runner add_eval_command(CLI::App& app) {
  auto o = std::make_shared<EvalOptions>();
  CLI::App* cmd = app.add_subcommand("eval", "Render the test views with the recovered asset and score them against the ground truth");
  cmd->add_option("--dataset", o->dataset, "dataset folder (transforms_test.json, test_XXX/ with ground truth)")->required();
  cmd->add_option("--result", o->result, "result folder of `ptir optimize` (gaussians.ply, env.exr); writes RESULT/eval/")
      ->required();
  cmd->add_option("--relight", o->relight, "NAME=env.exr: also relight under this environment (repeatable); "
                                           "compared with test_XXX/rgba_NAME.png when present");
  cmd->add_option("--spp", o->spp, "samples per pixel of the path-traced renders")->capture_default_str();
  cmd->add_option("--bounces", o->bounces, "indirect bounces")->capture_default_str();
  cmd->add_option("--aov-spp", o->aov_spp, "jittered samples per pixel of the material AOVs")->capture_default_str();
  cmd->add_option("--split", o->split, "dataset split to evaluate (transforms_<split>.json)")->capture_default_str();
  cmd->add_option("--scene", o->scene, "scene file whose meshes and lights join the asset (as in optimize --scene)");
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  cli::add_brdf_option(cmd, &o->brdf);
  cmd->add_option("--sheet-views", o->sheet_views, "views shown in the contact sheets (0: no sheets)")->capture_default_str();
  cmd->add_option("--threads", o->threads, "limit worker threads (0: all)");
  cmd->add_flag("-q,--quiet", o->quiet, "no progress output");
  add_force_flag(cmd, o->force);
  add_filter_flags(cmd, &o->filter);
  add_capture_flags(cmd, &o->capture);
  return [o, cmd] { return run_eval(*o, *cmd); };
}

}  // namespace ptir::cli
