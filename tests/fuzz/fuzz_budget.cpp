// Budget strings (`ptir optimize --budget`, `ptir fit --budget`): any bytes as
// the option's text, parsed into seconds (optim/budget_plan.cpp:
// parse_duration). A budget accepted must be a finite positive duration.
// Seeds: tests/fuzz/corpus/budget/.
#include <cmath>
#include <cstdlib>

#include "fuzz_common.h"
#include "ptir/optim/budget_plan.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  ptir_fuzz::expect_only_ptir_errors([&] {
    const double s = ptir::parse_duration(text, "--budget");
    if (!(std::isfinite(s) && s > 0.0)) {
      std::fprintf(stderr, "fuzz finding: --budget '%s' accepted as %g s\n", text.c_str(), s);
      std::abort();
    }
  });
  return 0;
}
