#include "ptir/scene/camera.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include <OpenImageIO/imageio.h>

#include "ptir/core/error.h"
#include "ptir/scene/json_limits.h"

namespace ptir {

namespace fs = std::filesystem;

Ray Camera::generate_ray(float px, float py) const {
  // Image plane at z = -1 in camera space; (px, py) in this (possibly cropped)
  // image, continuous coordinates from the top-left corner (see camera.h).
  const float u = px + float(crop_x), v = py + float(crop_y);
  const float x = (u - cx) / fx;
  const float y = (cy - v) / fy;
  Ray ray;
  ray.o = cam_to_world.translation;
  ray.d = normalize(cam_to_world.vector(Vec3(x, y, -1.0f)));
  return ray;
}

Camera Camera::resized(int w, int h) const {
  if (w <= 0 || h <= 0 || w > 65536 || h > 65536)
    throw Error(name, "image size must be 1..65536 pixels a side (got " + std::to_string(w) + "x" + std::to_string(h) + ")");
  const int fw = full_width > 0 ? full_width : width, fh = full_height > 0 ? full_height : height;
  const float sx = float(w) / float(fw), sy = float(h) / float(fh);
  Camera c = *this;
  c.width = w;
  c.height = h;
  c.crop_x = c.crop_y = 0;
  c.full_width = c.full_height = 0;
  c.fx = fx * sx;
  c.fy = fy * sx;  // keeps the pixel aspect (and so the horizontal field of view)
  c.cx = cx * sx;
  c.cy = cy * sy;
  return c;
}

Camera Camera::crop(int x0, int y0, int w, int h) const {
  int fw = full_width > 0 ? full_width : width, fh = full_height > 0 ? full_height : height;
  int ax = crop_x + x0, ay = crop_y + y0;
  if (w <= 0 || h <= 0 || x0 < 0 || y0 < 0 || x0 + w > width || y0 + h > height)
    throw Error(name, "crop window " + std::to_string(w) + "x" + std::to_string(h) + "+" + std::to_string(x0) + "+" +
                          std::to_string(y0) + " is outside the " + std::to_string(width) + "x" + std::to_string(height) + " image");
  Camera c = *this;
  c.crop_x = ax;
  c.crop_y = ay;
  c.full_width = fw;
  c.full_height = fh;
  c.width = w;
  c.height = h;
  return c;
}

namespace {

// The rotation and centre of a row-major camera-to-world matrix (validated).
void set_pose(Camera& cam, const float m[16]) {
  for (int i = 0; i < 16; ++i)
    if (!std::isfinite(m[i])) throw Error(cam.name, "camera matrix has a non-finite entry");
  Vec3 right(m[0], m[4], m[8]), up(m[1], m[5], m[9]), back(m[2], m[6], m[10]);
  // Cameras may carry a uniform scale (some exporters); strip it so rays stay unit length.
  right = normalize(right);
  up = normalize(up);
  back = normalize(back);
  if (length_sq(right) == 0 || length_sq(up) == 0 || length_sq(back) == 0 || std::fabs(dot(cross(right, up), back)) < 0.5f)
    throw Error(cam.name, "camera matrix rotation is degenerate");
  cam.cam_to_world.linear = Mat3::from_cols(right, up, back);
  cam.cam_to_world.translation = Vec3(m[3], m[7], m[11]);
}

void check_size(const std::string& name, int width, int height) {
  if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
    throw Error(name, "image size must be 1..65536 pixels a side (got " + std::to_string(width) + "x" + std::to_string(height) + ")");
}

}  // namespace

Camera make_camera(const float m[16], float fov_x, int width, int height, const std::string& name) {
  if (!(fov_x > 0.0f && fov_x < kPi)) throw Error(name, "field of view must be in (0, pi) radians, got " + std::to_string(fov_x));
  check_size(name, width, height);
  Camera cam;
  cam.name = name;
  cam.fov_x = fov_x;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = 0.5f * float(width) / std::tan(0.5f * fov_x);
  cam.cx = 0.5f * float(width);
  cam.cy = 0.5f * float(height);
  set_pose(cam, m);
  return cam;
}

Camera make_pinhole_camera(const float m[16], float fx, float fy, float cx, float cy, int width, int height,
                           const std::string& name) {
  for (float v : {fx, fy, cx, cy})
    if (!std::isfinite(v)) throw Error(name, "camera intrinsics have a non-finite value");
  if (!(fx > 0.0f && fy > 0.0f))
    throw Error(name, "focal lengths must be positive (got fx " + std::to_string(fx) + ", fy " + std::to_string(fy) + ")");
  check_size(name, width, height);
  Camera cam;
  cam.name = name;
  cam.width = width;
  cam.height = height;
  cam.fx = fx;
  cam.fy = fy;
  cam.cx = cx;
  cam.cy = cy;
  cam.fov_x = 2.0f * std::atan(0.5f * float(width) / fx);
  set_pose(cam, m);
  return cam;
}

std::string resolve_image_path(const std::string& folder, const std::string& file_path) {
  fs::path p = fs::path(folder) / fs::path(file_path);
  if (p.has_extension() && fs::exists(p)) return p.lexically_normal().string();
  for (const char* ext : {".png", ".exr", ".jpg", ".jpeg", ".PNG", ".EXR"}) {
    fs::path q = p;
    q += ext;
    if (fs::exists(q)) return q.lexically_normal().string();
  }
  return "";
}

namespace {

std::string frame_name(const std::string& file_path, size_t index) {
  // "./test_004/rgba" -> "test_004"; "./test/r_4" -> "r_4"
  fs::path p(file_path);
  std::string stem = p.stem().string();
  std::string parent = p.parent_path().filename().string();
  if ((stem == "rgba" || stem == "rgb") && !parent.empty()) return parent;
  return stem.empty() ? "frame_" + std::to_string(index) : stem;
}

}  // namespace

std::vector<Camera> load_transforms_json(const std::string& path, int width, int height) {
  const nlohmann::json j = load_json_file(path, "transforms file");  // regular file, size cap, bounded nesting
  if (!j.is_object()) throw Error(path, "top level must be an object");
  if ((!j.contains("camera_angle_x") || !j["camera_angle_x"].is_number()) && !j.contains("fl_x"))
    throw Error(path, "missing number 'camera_angle_x' (or 'fl_x')");
  for (const char* k : {"k1", "k2", "k3", "k4", "p1", "p2"})
    if (j.contains(k) && j[k].is_number() && j[k].get<double>() != 0.0)
      throw Error(path, std::string("the lens is distorted ('") + k +
                            "' is not 0): read it as a dataset (ptir optimize --dataset), which undistorts the images");
  if (!j.contains("frames") || !j["frames"].is_array() || j["frames"].empty())
    throw Error(path, "missing or empty array 'frames'");
  float fov_x = j.contains("camera_angle_x") && j["camera_angle_x"].is_number() ? j["camera_angle_x"].get<float>() : 0.0f;
  std::string folder = fs::path(path).parent_path().string();
  if (width <= 0 && j.contains("w") && j["w"].is_number()) width = j["w"].get<int>();
  if (height <= 0 && j.contains("h") && j["h"].is_number()) height = j["h"].get<int>();

  std::vector<Camera> cameras;
  const auto& frames = j["frames"];
  for (size_t f = 0; f < frames.size(); ++f) {
    const auto& fr = frames[f];
    std::string where = "frames[" + std::to_string(f) + "]";
    if (!fr.is_object() || !fr.contains("transform_matrix")) throw Error(path, where + " has no 'transform_matrix'");
    const auto& tm = fr["transform_matrix"];
    if (!tm.is_array() || tm.size() != 4) throw Error(path, where + ".transform_matrix must be 4x4");
    float m[16];
    for (int r = 0; r < 4; ++r) {
      if (!tm[r].is_array() || tm[r].size() != 4) throw Error(path, where + ".transform_matrix must be 4x4");
      for (int c = 0; c < 4; ++c) {
        if (!tm[r][c].is_number()) throw Error(path, where + ".transform_matrix has a non-number");
        m[r * 4 + c] = tm[r][c].get<float>();
      }
    }
    std::string file_path = fr.contains("file_path") && fr["file_path"].is_string() ? fr["file_path"].get<std::string>() : "";
    std::string image = file_path.empty() ? "" : resolve_image_path(folder, file_path);
    // Size from the image header when neither the caller nor the JSON gave one.
    int w = width, h = height;
    if ((w <= 0 || h <= 0) && !image.empty()) {
      auto inp = OIIO::ImageInput::open(image);
      if (!inp) throw Error(image, "cannot read image header: " + OIIO::geterror());
      w = inp->spec().width;
      h = inp->spec().height;
      width = w;
      height = h;
    }
    if (w <= 0 || h <= 0)
      throw Error(path, "image size unknown: give width/height (no 'w'/'h' keys and no readable image for " + where + ")");
    float frame_fov = fov_x;
    if (fr.contains("camera_angle_x") && fr["camera_angle_x"].is_number()) frame_fov = fr["camera_angle_x"].get<float>();
    // Pinhole intrinsics (instant-ngp / nerfstudio keys, the frame's first): fl_x
    // [fl_y, cx, cy] in pixels of the 'w' x 'h' image the file describes.
    auto key = [&](const char* k) -> const nlohmann::json* {
      if (fr.contains(k) && fr[k].is_number()) return &fr[k];
      if (j.contains(k) && j[k].is_number()) return &j[k];
      return nullptr;
    };
    try {
      if (const nlohmann::json* flx = key("fl_x")) {
        const double sx = (j.contains("w") && j["w"].is_number()) ? double(w) / j["w"].get<double>() : 1.0;
        const double sy = (j.contains("h") && j["h"].is_number()) ? double(h) / j["h"].get<double>() : 1.0;
        const double fx = flx->get<double>();
        const double fy = key("fl_y") ? key("fl_y")->get<double>() : fx;
        const double cx = key("cx") ? key("cx")->get<double>() : 0.5 * w / sx;
        const double cy = key("cy") ? key("cy")->get<double>() : 0.5 * h / sy;
        Camera cam = make_pinhole_camera(m, float(fx * sx), float(fy * sx), float(cx * sx), float(cy * sy), w, h,
                                         frame_name(file_path, f));
        cam.image_path = image;
        cameras.push_back(cam);
        continue;
      }
      Camera cam = make_camera(m, frame_fov, w, h, frame_name(file_path, f));
      cam.image_path = image;
      cameras.push_back(cam);
    } catch (const Error& e) {
      throw Error(path, where + ": " + e.what());
    }
  }
  return cameras;
}

}  // namespace ptir
