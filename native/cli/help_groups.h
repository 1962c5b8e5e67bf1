// `--help` that lists the options most runs need, and `--help-all` every one: the
// others go to an "Advanced options" group the plain help leaves out (with a footer
// saying how many there are and how to see them).
#pragma once

#include <set>
#include <string>

#include <CLI/CLI.hpp>

namespace ptir::cli {

// Moves every option of cmd not named in `common` to the advanced group and installs
// the formatter and the --help-all flag.
void show_common_options(CLI::App* cmd, const std::set<std::string>& common);

}  // namespace ptir::cli
