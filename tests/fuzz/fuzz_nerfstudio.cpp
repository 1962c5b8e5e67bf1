// nerfstudio / instant-ngp datasets (scene/dataset_nerfstudio.cpp): any bytes as
// DIR/transforms.json beside two real 8x6 photos (images/a.png, images/b.png),
// loaded as `ptir optimize --dataset DIR` loads it. Seeds: tests/fuzz/corpus/nerfstudio/.
#include "fuzz_common.h"
#include "ptir/io/image.h"
#include "ptir/scene/dataset.h"

namespace {

const std::filesystem::path& dataset_dir() {
  static const std::filesystem::path dir = [] {
    auto d = ptir_fuzz::scratch() / "nerfstudio";
    std::filesystem::create_directories(d / "images");
    ptir::Image img(8, 6, {"R", "G", "B"});
    for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = float(i % 7) / 7.0f;
    ptir::write_image((d / "images/a.png").string(), img, ptir::Encoding::Colour);
    ptir::write_image((d / "images/b.png").string(), img, ptir::Encoding::Colour);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto& dir = dataset_dir();
  ptir_fuzz::write_file(dir / "transforms.json", data, size);
  ptir_fuzz::expect_only_ptir_errors([&] {
    ptir::DatasetOptions options;
    ptir::load_dataset(dir.string(), options);
  });
  return 0;
}
