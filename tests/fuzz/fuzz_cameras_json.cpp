// A 3DGS cameras.json as `ptir optimize --gaussians IN.ply --cameras FILE`
// reads it (scene/dataset_3dgs.cpp: load_3dgs_cameras), each camera then
// resized to the PLY-only targets' size, as the radiance stage does.
// Seeds: tests/fuzz/corpus/cameras_json/.
#include "fuzz_common.h"
#include "ptir/scene/dataset.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = ptir_fuzz::write_file(ptir_fuzz::scratch() / "cameras.json", data, size);
  ptir_fuzz::expect_only_ptir_errors([&] {
    for (const ptir::Camera& c : ptir::load_3dgs_cameras(path)) {
      const ptir::Camera small = c.resized(64, 48);
      small.generate_ray(32.0f, 24.0f);
    }
  });
  return 0;
}
