// ptir: command-line front end of the engine (render; optimize, relight and eval
// join as they land). Errors print "ptir: error: <file>: <problem>" and exit 1;
// usage errors exit 2.
#include <cstdio>
#include <exception>

#include "commands.h"
#include "ptir/core/error.h"

int main(int argc, char** argv) {
  CLI::App app{"PTIR: path-traced inverse rendering of 3D Gaussian splats"};
  app.require_subcommand(1);
  ptir::cli::Runner render = ptir::cli::add_render_command(app);
  ptir::cli::Runner optimize = ptir::cli::add_optimize_command(app);
  ptir::cli::Runner eval = ptir::cli::add_eval_command(app);
  ptir::cli::Runner relight = ptir::cli::add_relight_command(app);
  ptir::cli::Runner fit = ptir::cli::add_fit_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (app.got_subcommand("render")) return render();
    if (app.got_subcommand("optimize")) return optimize();
    if (app.got_subcommand("eval")) return eval();
    if (app.got_subcommand("relight")) return relight();
    if (app.got_subcommand("fit")) return fit();
  } catch (const ptir::Cancelled&) {
    std::fprintf(stderr, "ptir: cancelled\n");
    return 130;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptir: error: %s\n", e.what());
    return 1;
  }
  return 2;
}
