#include "ptir/scene/camera.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include <OpenImageIO/imageio.h>

#include "ptir/core/error.h"

namespace ptir {

namespace fs = std::filesystem;

Ray Camera::generate_ray(float px, float py) const {
  // Image plane at z = -1 in camera space; x spans [-tan(fov_x/2), tan(fov_x/2)] over the full image.
  float fw = float(full_width > 0 ? full_width : width), fh = float(full_height > 0 ? full_height : height);
  px += float(crop_x);
  py += float(crop_y);
  float tan_half = std::tan(0.5f * fov_x);
  float x = (2.0f * px / fw - 1.0f) * tan_half;
  float y = (1.0f - 2.0f * py / fh) * tan_half * fh / fw;
  Ray ray;
  ray.o = cam_to_world.translation;
  ray.d = normalize(cam_to_world.vector(Vec3(x, y, -1.0f)));
  return ray;
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

Camera make_camera(const float m[16], float fov_x, int width, int height, const std::string& name) {
  for (int i = 0; i < 16; ++i)
    if (!std::isfinite(m[i])) throw Error(name, "camera matrix has a non-finite entry");
  if (!(fov_x > 0.0f && fov_x < kPi)) throw Error(name, "field of view must be in (0, pi) radians, got " + std::to_string(fov_x));
  if (width <= 0 || height <= 0 || width > 65536 || height > 65536)
    throw Error(name, "image size must be positive (got " + std::to_string(width) + "x" + std::to_string(height) + ")");
  Camera cam;
  cam.name = name;
  cam.fov_x = fov_x;
  cam.width = width;
  cam.height = height;
  Vec3 right(m[0], m[4], m[8]), up(m[1], m[5], m[9]), back(m[2], m[6], m[10]);
  // Cameras may carry a uniform scale (some exporters); strip it so rays stay unit length.
  right = normalize(right);
  up = normalize(up);
  back = normalize(back);
  if (length_sq(right) == 0 || length_sq(up) == 0 || length_sq(back) == 0 || std::fabs(dot(cross(right, up), back)) < 0.5f)
    throw Error(name, "camera matrix rotation is degenerate");
  cam.cam_to_world.linear = Mat3::from_cols(right, up, back);
  cam.cam_to_world.translation = Vec3(m[3], m[7], m[11]);
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
  std::ifstream in(path);
  if (!in) throw Error(path, "cannot open file");
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    throw Error(path, std::string("invalid JSON: ") + e.what());
  }
  if (!j.is_object()) throw Error(path, "top level must be an object");
  if (!j.contains("camera_angle_x") || !j["camera_angle_x"].is_number())
    throw Error(path, "missing number 'camera_angle_x'");
  if (!j.contains("frames") || !j["frames"].is_array() || j["frames"].empty())
    throw Error(path, "missing or empty array 'frames'");
  float fov_x = j["camera_angle_x"].get<float>();
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
    try {
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
