// Gaussian PLY files (io/ply*.cpp, scene/gaussian_ply.cpp): plain 3DGS layouts
// and SuperSplat's compressed one, read as a scene's gaussians entry reads them.
// Seeds: tests/fuzz/corpus/ply/ (both layouts, ASCII and binary).
#include "fuzz_common.h"
#include "ptir/scene/gaussian_ply.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = ptir_fuzz::write_file(ptir_fuzz::scratch() / "in.ply", data, size);
  ptir_fuzz::expect_only_ptir_errors([&] { ptir::load_gaussians(path); });
  return 0;
}
