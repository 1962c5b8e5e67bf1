// Which options a run was given explicitly, by their command-line names
// ("--iters", "--crop"): the pipeline's defaults that depend on the inputs (a
// budget's batch, the radiance targets' defaults, a resumed run's spp) apply only
// where the option was not given. `ptir optimize` fills it from its command line,
// the Python module from the keyword arguments it was called with.
#pragma once

#include <set>
#include <string>

namespace ptir::pipeline {

using GivenOptions = std::set<std::string>;

}  // namespace ptir::pipeline
