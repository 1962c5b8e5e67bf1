#include "output_guard.h"

namespace ptir::cli {

void add_force_flag(CLI::App* cmd, bool& force) {
  cmd->add_flag("--force", force, "write the outputs even where they would replace input files");
}

}  // namespace ptir::cli
