#include "ptir/eval/capture_result.h"

#include <filesystem>
#include <system_error>

#include "ptir/core/error.h"
#include "ptir/scene/capture_calibration.h"

namespace ptir::eval {

namespace fs = std::filesystem;

namespace {
bool is_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}
}  // namespace

void read_photos_as_the_run_did(Dataset& data, const std::string& result) {
  const fs::path calibration = fs::path(result) / "capture" / "calibration.json";
  if (is_file(calibration) && !read_capture_calibration(calibration.string()).exif_exposure)
    for (DatasetView& v : data.views) v.exposure = 1.0;
}

Image capture_object_mask(const std::string& result, const std::string& name, int width, int height) {
  const fs::path f = fs::path(result) / "capture" / "masks" / (name + ".png");
  if (name.empty() || !is_file(f)) return Image();
  const Image png = read_image(f.string(), Encoding::Data);
  if (png.width != width || png.height != height)
    throw Error(f.string(), "is " + std::to_string(png.width) + "x" + std::to_string(png.height) + ", the photo " +
                                std::to_string(width) + "x" + std::to_string(height));
  Image m(width, height, {"Y"});
  for (size_t k = 0; k < m.pixels.size(); ++k) m.pixels[k] = png.pixels[k * size_t(png.channels)] > 0.5f ? 1.0f : 0.0f;
  return m;
}

}  // namespace ptir::eval
