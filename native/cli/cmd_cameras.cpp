// `ptir cameras`: the cameras of any dataset PTIR reads (NeRF, COLMAP, 3DGS
// output, nerfstudio) as one NeRF-style transforms file, for tools that only
// read that (the Blender add-on imports them as cameras with the photo behind).
//
//   ptir cameras --dataset DIR [--split all] -o cameras.json [capture switches]
//
// Each frame: "name", "file_path" (absolute: the image the optimiser reads -- for
// a distorted lens the undistorted, cached photo), "transform_matrix" (camera to
// world, camera looking down -z with +y up, as Blender's), the pinhole "fl_x",
// "fl_y", "cx", "cy" in pixels and "camera_angle_x", and "exposure" where EXIF
// gave one; top level "layout", "w", "h" and the first frame's "camera_angle_x". The file is written atomically.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "capture_flags.h"
#include "commands.h"
#include "output_guard.h"
#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/scene/dataset.h"

namespace ptir::cli {

namespace {

struct CamerasOptions {
  std::string dataset, out, split = "all";
  CaptureFlags capture;
  bool force = false;
};

nlohmann::ordered_json camera_frame(const Camera& c, double exposure) {
  nlohmann::ordered_json f;
  f["name"] = c.name;
  f["file_path"] = std::filesystem::absolute(c.image_path).lexically_normal().string();
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    m.push_back({c.cam_to_world.linear.m[r][0], c.cam_to_world.linear.m[r][1], c.cam_to_world.linear.m[r][2],
                 c.cam_to_world.translation[r]});
  m.push_back({0.0, 0.0, 0.0, 1.0});
  f["transform_matrix"] = m;
  f["fl_x"] = c.fx;
  f["fl_y"] = c.fy;
  f["cx"] = c.cx;
  f["cy"] = c.cy;
  f["camera_angle_x"] = 2.0 * std::atan(0.5 * double(c.width) / double(c.fx));
  if (exposure != 1.0) f["exposure"] = exposure;
  return f;
}

int run_cameras(const CamerasOptions& o) {
  DatasetOptions d;
  apply_capture_flags(o.capture, d);
  d.split = o.split;
  guard_outputs({{}, {o.dataset}, {}, {o.dataset}}, {{o.out}, {}}, o.force);
  std::unique_ptr<Dataset> data;
  if (o.split == "all" && detect_layout(o.dataset) == "nerf") {
    // NeRF layouts keep their splits in separate files: all = train then test.
    data = std::make_unique<Dataset>();
    for (const char* s : {"train", "test"}) {
      d.split = s;
      if (!std::filesystem::exists(std::filesystem::path(o.dataset) / (std::string("transforms_") + s + ".json"))) continue;
      auto part = load_dataset(o.dataset, d);
      data->layout = part->layout;
      data->width = part->width;
      data->height = part->height;
      for (auto& v : part->views) data->views.push_back(v);
    }
    if (data->views.empty()) throw Error(o.dataset, "no transforms_train.json or transforms_test.json");
  } else {
    data = load_dataset(o.dataset, d);
  }
  nlohmann::ordered_json j;
  j["layout"] = data->layout;
  j["w"] = data->width;
  j["h"] = data->height;
  // NeRF readers want a top-level field of view; every frame carries its own pinhole, which wins.
  const Camera& c0 = data->views.front().camera;
  j["camera_angle_x"] = 2.0 * std::atan(0.5 * double(c0.width) / double(c0.fx));
  j["frames"] = nlohmann::json::array();
  for (const DatasetView& v : data->views) j["frames"].push_back(camera_frame(v.camera, v.exposure));
  io::write_text_atomic(o.out, j.dump(1) + "\n");
  std::fprintf(stderr, "wrote %s: %zu cameras (%s, %dx%d)\n", o.out.c_str(), data->views.size(), data->layout.c_str(),
               data->width, data->height);
  return 0;
}

}  // namespace

Runner add_cameras_command(CLI::App& app) {
  auto o = std::make_shared<CamerasOptions>();
  CLI::App* cmd = app.add_subcommand("cameras", "Write a dataset's cameras (any layout) as one NeRF-style transforms file");
  cmd->add_option("--dataset", o->dataset, "dataset folder (NeRF, COLMAP, 3DGS output, nerfstudio)")->required();
  cmd->add_option("-o,--out", o->out, "output .json")->required();
  cmd->add_option("--split", o->split, "train, test or all")->capture_default_str();
  add_force_flag(cmd, o->force);
  add_capture_flags(cmd, &o->capture);
  return [o] { return run_cameras(*o); };
}

}  // namespace ptir::cli
