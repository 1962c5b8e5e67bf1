// The PLY-only plan (`ptir optimize --gaussians IN.ply` without --dataset or
// --cameras): a Gaussian PLY read as every command reads it
// (scene/gaussian_ply.cpp, materials checked: material/material_range.h),
// then the orbit of virtual cameras planned around it (scene/orbit_views.cpp)
// and written as OUT/views.json is. The first byte picks the orbit's options.
// Seeds: tests/fuzz/corpus/orbit/.
#include "fuzz_common.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/orbit_views.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string path = ptir_fuzz::write_file(ptir_fuzz::scratch() / "orbit.ply", data + 1, size - 1);
  ptir::OrbitOptions o;
  o.views = 1 + (data[0] & 7);  // a few views: the plan, not its count, is under test
  o.size = 16 << ((data[0] >> 3) & 3);
  if (data[0] & 32) o.fov_deg = 5.0f;
  if (data[0] & 64) o.elevation_min = 10.0f;
  ptir_fuzz::expect_only_ptir_errors([&] {
    const ptir::GaussianField field = ptir::load_gaussians(path);
    const ptir::OrbitPlan plan = ptir::plan_orbit(field, o);
    ptir::orbit_plan_json(plan, path);
  });
  return 0;
}
