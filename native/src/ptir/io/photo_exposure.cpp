#include "ptir/io/photo_exposure.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>

namespace ptir {

double PhotoExposure::value() const {
  const double n = f_number > 0.0 ? f_number : 1.0;
  const double s = iso > 0.0 ? iso : 1.0;
  return exposure_time * s / (n * n);
}

std::optional<PhotoExposure> read_photo_exposure(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    (void)OIIO::geterror();
    return std::nullopt;
  }
  const OIIO::ImageSpec& spec = in->spec();
  PhotoExposure e;
  e.exposure_time = spec.get_float_attribute("ExposureTime", 0.0f);
  e.f_number = spec.get_float_attribute("FNumber", 0.0f);
  e.iso = spec.get_float_attribute("Exif:PhotographicSensitivity", 0.0f);
  if (e.iso <= 0.0) e.iso = spec.get_int_attribute("Exif:PhotographicSensitivity", 0);
  if (e.iso <= 0.0) e.iso = spec.get_float_attribute("Exif:ISOSpeedRatings", 0.0f);
  if (e.iso <= 0.0) e.iso = spec.get_int_attribute("Exif:ISOSpeedRatings", 0);
  in->close();
  if (!(e.exposure_time > 0.0)) return std::nullopt;
  return e;
}

}  // namespace ptir

namespace ptir {

std::vector<double> relative_exposures(const std::vector<std::optional<PhotoExposure>>& photos) {
  if (photos.empty()) return {};
  bool all_n = true, all_s = true;
  for (const auto& p : photos) {
    if (!p) return {};
    all_n = all_n && p->f_number > 0.0;
    all_s = all_s && p->iso > 0.0;
  }
  std::vector<double> h;
  for (const auto& p : photos) {
    PhotoExposure e = *p;
    if (!all_n) e.f_number = 0.0;
    if (!all_s) e.iso = 0.0;
    h.push_back(e.value());
  }
  std::vector<double> sorted = h;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double ref = sorted[sorted.size() / 2];
  for (double& v : h) v /= ref;
  return h;
}

}  // namespace ptir
