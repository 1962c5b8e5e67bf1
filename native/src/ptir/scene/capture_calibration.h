// What the capture analysis (optim/capture_analysis.h) decided about a real
// capture's photos, as one file that every command reading the capture applies
// (DatasetOptions::calibration; `ptir optimize` writes OUT/capture/calibration.json):
//
//   {"subject": "object", "exif_exposure": false,
//    "masks": "masks",                      folder beside the file: <view name>.png, the
//                                           input splat's coverage (1 = the object's pixel)
//    "views": {"IMG_3496": {"gain": [r, g, b]}, ...},
//                                           each photo is divided by its gain (linear, per
//                                           channel): the camera's exposure and white
//                                           balance against the capture's consensus
//    "record": {...}}                       the analysis' numbers (OUT/settings.json "capture")
//
// A view the file does not name keeps its photo as read; a named mask that does not
// exist is an error naming it.
#pragma once

#include <array>
#include <map>
#include <string>

namespace ptir {

class Dataset;

struct CaptureCalibration {
  std::string subject;        // "object" or "scene"
  bool exif_exposure = true;  // false: the photos' EXIF exposure is not applied
  std::string masks_dir;      // absolute; "" = no masks
  std::map<std::string, std::array<float, 3>> gain;  // view name -> per-channel gain
  std::string record_json;    // the analysis' record (JSON text), "" = none
};

CaptureCalibration read_capture_calibration(const std::string& path);
void write_capture_calibration(const std::string& path, const CaptureCalibration& c);

// Applies it to a loaded capture's views (masks, gains; EXIF off resets each
// view's exposure to 1) and keeps the record in data.calibration_record.
void apply_capture_calibration(Dataset& data, const CaptureCalibration& c, const std::string& path_for_messages);

}  // namespace ptir
