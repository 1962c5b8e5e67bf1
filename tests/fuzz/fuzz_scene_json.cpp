// Scene files (scene/scene_json.cpp): any bytes as scene.json, read as `ptir
// render` reads it. Seeds: tests/fuzz/corpus/scene_json/.
#include "fuzz_common.h"
#include "ptir/scene/scene_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = ptir_fuzz::write_file(ptir_fuzz::scratch() / "scene.json", data, size);
  ptir_fuzz::expect_only_ptir_errors([&] { ptir::load_scene_json(path); });
  return 0;
}
