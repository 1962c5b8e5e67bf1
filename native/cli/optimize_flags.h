// What `ptir optimize` registers beside its own switches (cmd_optimize.cpp): the
// inversion's learning options (loss, regularisers, learning rates, what is
// learnt), and the names of the options a command line gave (the pipeline's
// defaults that depend on the inputs apply only to the others:
// pipeline/given_options.h).
#pragma once

#include <CLI/CLI.hpp>

#include <set>
#include <string>

#include "ptir/optim/optimizer_setup.h"

namespace ptir::cli {

// --loss-space ... --learn-exposure (their order is the --help-all listing's).
void add_learning_flags(CLI::App* cmd, OptimizeOptions* opt);

// "--iters", "--crop", ...: every long name of every option given on the command line.
std::set<std::string> given_options(const CLI::App& cmd);

}  // namespace ptir::cli
