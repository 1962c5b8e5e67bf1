// ptir: command-line front end of the engine (render; optimize, relight and eval
// join as they land). Errors print "ptir: error: <file>: <problem>" and exit 1;
// usage errors exit 2.
//
// Under an MPI launcher (`mpirun -np N ptir ...`, native/mpi/world.h) every rank
// runs this same program: rank 0 alone prints usage and progress and writes the
// outputs; an error on any rank is printed with its rank and ends the whole job.
// Ranks that share a machine share its cores: each uses at most cores / (ranks on
// the machine) worker threads (--threads can only lower that).
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <optional>

#include "commands.h"
#include "ptir/core/error.h"
#include "world.h"

namespace {

int run(int argc, char** argv, const ptir::Communicator& comm) {
  CLI::App app{"PTIR: path-traced inverse rendering of 3D Gaussian splats"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("ptir " PTIR_VERSION " (MPI: ") + ptir::world_library() + ")");
  ptir::cli::Runner render = ptir::cli::add_render_command(app);
  ptir::cli::Runner optimize = ptir::cli::add_optimize_command(app);
  ptir::cli::Runner eval = ptir::cli::add_eval_command(app);
  ptir::cli::Runner relight = ptir::cli::add_relight_command(app);
  ptir::cli::Runner serve = ptir::cli::add_serve_command(app);
  ptir::cli::Runner cameras = ptir::cli::add_cameras_command(app);
  ptir::cli::Runner fit = ptir::cli::add_fit_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (comm.rank() != 0) return e.get_exit_code() == 0 ? 0 : 2;  // every rank parsed the same: rank 0 says it
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (comm.size() > 1 && app.got_subcommand("relight")) {
    // Not split across ranks (yet): N copies would race on the same outputs.
    if (comm.rank() == 0) std::fprintf(stderr, "ptir: error: relight runs as one process: start it without mpirun\n");
    return 2;
  }
  try {
    if (app.got_subcommand("render")) return render();
    if (app.got_subcommand("optimize")) return optimize();
    if (app.got_subcommand("eval")) return eval();
    if (app.got_subcommand("relight")) return relight();
    if (app.got_subcommand("serve")) return serve();
    if (app.got_subcommand("cameras")) return cameras();
    if (app.got_subcommand("fit")) return fit();
  } catch (const ptir::Cancelled&) {
    std::fprintf(stderr, "ptir: cancelled\n");
    return 130;
  } catch (const std::exception& e) {
    if (comm.size() == 1) {
      std::fprintf(stderr, "ptir: error: %s\n", e.what());
      return 1;
    }
    // The other ranks may wait in a collective for this one: end the job.
    std::fprintf(stderr, "ptir: error (rank %d of %d): %s\n", comm.rank(), comm.size(), e.what());
    std::fflush(stderr);
    comm.abort(1);
    return 1;
  }
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  const ptir::Communicator* comm = nullptr;
  try {
    comm = &ptir::init_world(&argc, &argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptir: error: %s\n", e.what());
    return 1;
  }
  std::optional<tbb::global_control> share_cores;
  if (comm->local_size() > 1)
    share_cores.emplace(tbb::global_control::max_allowed_parallelism,
                        size_t(std::max(1, tbb::info::default_concurrency() / comm->local_size())));
  const int rc = run(argc, argv, *comm);
  share_cores.reset();
  ptir::finalize_world();
  return rc;
}
