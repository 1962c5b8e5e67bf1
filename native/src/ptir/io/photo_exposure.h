// Exposure of a photograph from its EXIF metadata (OpenImageIO's names):
//   ExposureTime t (seconds), FNumber N, ISO S (Exif:PhotographicSensitivity or
//   Exif:ISOSpeedRatings).
// The light a pixel records is proportional to the scene radiance times
//   H = t S / N^2
// (exposure time x sensitivity / aperture area), so photographs of one scene
// taken with different settings agree once each is divided by its H relative
// to a reference (dataset.h: the median H of the capture's photos). A missing
// FNumber or ISO counts as the same for every photo (factor 1); without
// ExposureTime the photo has no exposure.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace ptir {

struct PhotoExposure {
  double exposure_time = 0.0;  // seconds (> 0)
  double f_number = 0.0;       // 0 = not recorded
  double iso = 0.0;            // 0 = not recorded
  // t S / N^2, with absent N or S taken as 1.
  double value() const;
};

// The EXIF exposure of the image file at `path`, or nothing when the file
// records no ExposureTime (or cannot be opened: the dataset reports that itself).
std::optional<PhotoExposure> read_photo_exposure(const std::string& path);

}  // namespace ptir

namespace ptir {

// Each photo's t S / N^2 over the median of the set (so the typical photo keeps
// its values), or an empty vector when some photo records no ExposureTime.
// FNumber and ISO count only when every photo records them.
std::vector<double> relative_exposures(const std::vector<std::optional<PhotoExposure>>& photos);

}  // namespace ptir
