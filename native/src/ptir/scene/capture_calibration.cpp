#include "ptir/scene/capture_calibration.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/scene/dataset.h"

namespace ptir {

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

CaptureCalibration read_capture_calibration(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path, "cannot open the capture calibration");
  ojson j;
  try {
    j = ojson::parse(in);
  } catch (const std::exception& e) {
    throw Error(path, std::string("not valid JSON: ") + e.what());
  }
  CaptureCalibration c;
  try {
    c.subject = j.value("subject", std::string());
    c.exif_exposure = j.value("exif_exposure", true);
    const std::string masks = j.value("masks", std::string());
    if (!masks.empty()) c.masks_dir = (fs::path(path).parent_path() / masks).lexically_normal().string();
    if (j.contains("views"))
      for (const auto& kv : j.at("views").items()) {
        const auto& g = kv.value().at("gain");
        std::array<float, 3> gain{};
        for (int k = 0; k < 3; ++k) {
          gain[size_t(k)] = g.at(size_t(k)).get<float>();
          if (!(std::isfinite(gain[size_t(k)]) && gain[size_t(k)] > 0.0f))
            throw Error(path, "view '" + kv.key() + "': gains must be positive and finite");
        }
        c.gain[kv.key()] = gain;
      }
    if (j.contains("record")) c.record_json = j.at("record").dump();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path, std::string("malformed capture calibration: ") + e.what());
  }
  return c;
}

void write_capture_calibration(const std::string& path, const CaptureCalibration& c) {
  ojson j = ojson::object();
  j["subject"] = c.subject;
  j["exif_exposure"] = c.exif_exposure;
  if (!c.masks_dir.empty()) j["masks"] = fs::path(c.masks_dir).lexically_relative(fs::path(path).parent_path()).string();
  ojson views = ojson::object();
  for (const auto& kv : c.gain) views[kv.first] = {{"gain", {kv.second[0], kv.second[1], kv.second[2]}}};
  j["views"] = views;
  if (!c.record_json.empty()) j["record"] = ojson::parse(c.record_json);
  io::write_text_atomic(path, j.dump(1) + "\n");
}

void apply_capture_calibration(Dataset& data, const CaptureCalibration& c, const std::string& path) {
  for (DatasetView& v : data.views) {
    if (!c.exif_exposure) v.exposure = 1.0;
    const auto g = c.gain.find(v.camera.name);
    if (g != c.gain.end()) v.gain = g->second;
    if (!c.masks_dir.empty()) {
      const fs::path mask = fs::path(c.masks_dir) / (v.camera.name + ".png");
      std::error_code ec;
      if (!fs::is_regular_file(mask, ec))
        throw Error(path, "view '" + v.camera.name + "': its mask " + mask.string() + " is missing");
      v.files.mask = mask.string();
    }
  }
  data.calibration_record = c.record_json;
}

}  // namespace ptir
