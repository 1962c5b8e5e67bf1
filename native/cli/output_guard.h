// The commands' output guard (pipeline/output_guard.h: outputs never over the
// inputs, one writer per folder, stale temps cleared) and its --force switch.
#pragma once

#include <CLI/CLI.hpp>

#include "ptir/pipeline/output_guard.h"

namespace ptir::cli {

using pipeline::guard_outputs;
using pipeline::guard_result_folder;
using pipeline::Inputs;
using pipeline::lock_output_folder;
using pipeline::Outputs;
using pipeline::remove_stale_outputs;

// Adds --force (write even over the inputs) to a command.
void add_force_flag(CLI::App* cmd, bool& force);

}  // namespace ptir::cli
