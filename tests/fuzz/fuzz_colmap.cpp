// COLMAP models (scene/colmap_model.cpp): the input is split at "@@@@" into
// cameras, images and points3D; the first byte picks the binary (.bin) or text
// (.txt) files. Read with observations and points, as `ptir fit` reads them.
// Seeds: tests/fuzz/corpus/colmap/.
#include <vector>

#include "fuzz_common.h"
#include "ptir/scene/colmap_model.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  std::vector<std::string> parts;
  size_t start = 0;
  for (int i = 0; i < 2; ++i) {
    const size_t at = text.find("@@@@", start);
    if (at == std::string::npos) break;
    parts.push_back(text.substr(start, at - start));
    start = at + 4;
  }
  parts.push_back(text.substr(start));
  while (parts.size() < 3) parts.emplace_back();
  const bool binary = data[0] & 1;
  const auto dir = ptir_fuzz::scratch() / "colmap";
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  const char* names[3] = {"cameras", "images", "points3D"};
  for (int i = 0; i < 3; ++i)
    ptir_fuzz::write_file(dir / (std::string(names[i]) + (binary ? ".bin" : ".txt")), parts[size_t(i)]);
  ptir_fuzz::expect_only_ptir_errors([&] { ptir::read_colmap_model(dir.string(), true, true); });
  return 0;
}
