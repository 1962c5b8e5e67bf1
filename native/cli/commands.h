// Subcommands of the `ptir` command-line tool. Each registers its options on a
// CLI11 subcommand and returns the function that runs it.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace ptir::cli {

using Runner = std::function<int()>;

Runner add_render_command(CLI::App& app);
Runner add_optimize_command(CLI::App& app);
Runner add_eval_command(CLI::App& app);
Runner add_relight_command(CLI::App& app);
Runner add_serve_command(CLI::App& app);
Runner add_cameras_command(CLI::App& app);
Runner add_fit_command(CLI::App& app);

}  // namespace ptir::cli
