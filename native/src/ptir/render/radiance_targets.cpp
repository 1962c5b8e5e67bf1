// Training targets from the splats' own radiance (radiance_targets.h).
#include "ptir/render/radiance_targets.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/image.h"
#include "ptir/render/aov.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  if (in) ss << in.rdbuf();
  return ss.str();
}

// The largest alpha of an RGBA target.
float max_alpha_of(const Image& target) {
  float a = 0.0f;
  for (size_t p = 3; p < target.pixels.size(); p += 4) a = std::max(a, target.pixels[p]);
  return a;
}

// A cached view is reused when its header has the camera's size; *alpha: its largest alpha.
bool cached(const fs::path& image, const Camera& cam, float* alpha) {
  std::error_code ec;
  if (!fs::is_regular_file(image, ec)) return false;
  try {
    const Image probe = read_image(image.string(), Encoding::Data);
    if (probe.width != cam.width || probe.height != cam.height || probe.channels != 4) return false;
    *alpha = max_alpha_of(probe);
    return true;
  } catch (const Error&) {
    return false;  // a damaged file is rendered again
  }
}

std::string transforms_json(const std::vector<Camera>& cameras) {
  nlohmann::json j;
  j["w"] = cameras[0].width;
  j["h"] = cameras[0].height;
  j["camera_angle_x"] = cameras[0].fov_x;
  nlohmann::json frames = nlohmann::json::array();
  for (size_t i = 0; i < cameras.size(); ++i) {
    const Camera& c = cameras[i];
    nlohmann::json m = nlohmann::json::array();
    for (int r = 0; r < 3; ++r)
      m.push_back({c.cam_to_world.linear.m[r][0], c.cam_to_world.linear.m[r][1], c.cam_to_world.linear.m[r][2],
                   c.cam_to_world.translation[r]});
    m.push_back({0, 0, 0, 1});
    char name[48];
    std::snprintf(name, sizeof name, "./train/view_%03zu", i);
    frames.push_back({{"file_path", std::string(name) + ".exr"}, {"transform_matrix", m}, {"fl_x", c.fx},
                      {"fl_y", c.fy}, {"cx", c.cx}, {"cy", c.cy}});
  }
  j["frames"] = frames;
  return j.dump(1);
}

}  // namespace

RadianceTargetReport render_radiance_targets(const SceneAccel& accel, const std::vector<Camera>& cameras,
                                             const std::string& dir, const RadianceTargetSettings& s) {
  if (cameras.empty()) throw Error(dir, "no cameras to render radiance targets from");
  for (const Camera& c : cameras)
    if (c.width != cameras[0].width || c.height != cameras[0].height)
      throw Error(dir, "radiance targets need one image size (camera " + c.name + " differs)");
  const fs::path root(dir), train = root / "train", key_file = root / "key.txt";
  std::error_code ec;
  fs::create_directories(train, ec);
  if (ec) throw Error(train.string(), "cannot create folder: " + ec.message());
  io::remove_stale_temps(train);  // a run killed mid-write left its temp behind
  // A different input or plan: the cached views are stale.
  if (read_text(key_file) != s.key) {
    for (const auto& e : fs::directory_iterator(train))
      if (e.path().extension() == ".exr") fs::remove(e.path(), ec);
    fs::remove(root / "transforms_train.json", ec);
    io::write_text_atomic(key_file.string(), s.key);
  }
  AovSettings as;
  as.spp = s.spp;
  as.filter = s.filter;
  RenderControl control;
  control.cancel = s.cancel;
  RadianceTargetReport report;
  for (size_t i = 0; i < cameras.size(); ++i) {
    char name[48];
    std::snprintf(name, sizeof name, "view_%03zu.exr", i);
    const fs::path image = train / name;
    bool rendered = false;
    float alpha = 0.0f;
    if (!cached(image, cameras[i], &alpha)) {
      Image preview;
      try {
        preview = render_aov(accel, cameras[i], Aov::Preview, as, control);
      } catch (const Cancelled&) {
        report.cancelled = true;
        return report;
      }
      if (s.cancel && s.cancel->load()) {
        report.cancelled = true;
        return report;
      }
      write_image(image.string(), preview, Encoding::Data);  // associated, as EXR stores it
      alpha = max_alpha_of(preview);
      rendered = true;
    }
    report.max_alpha = std::max(report.max_alpha, alpha);
    (rendered ? report.rendered : report.reused)++;
    if (s.progress && !s.progress(int(i) + 1, int(cameras.size()), rendered)) {
      report.cancelled = true;
      return report;
    }
  }
  io::write_text_atomic((root / "transforms_train.json").string(), transforms_json(cameras));
  return report;
}

}  // namespace ptir
