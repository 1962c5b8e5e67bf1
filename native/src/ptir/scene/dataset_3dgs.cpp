// The 3DGS output folder (dataset.h), as INRIA's train.py writes it:
//   DIR/cameras.json   [{id, img_name (no extension), width, height, position (camera
//                      centre), rotation (camera-to-world 3x3, COLMAP axes: +x right,
//                      +y down, +z forward), fx, fy}], every train and test camera
//   DIR/cfg_args       Namespace(..., source_path='...', images='images', eval=True, ...)
//   DIR/point_cloud/iteration_N/point_cloud.ply
// Images come from <source_path>/<images>/<img_name>.<ext>. The principal point is
// the image centre, as 3DGS renders (its Gaussians were fitted that way), unless the
// entry has cx, cy (forks with off-centre projection write them).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/scene/json_limits.h"
#include "ptir/scene/dataset_layouts.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

// key=value pairs of a Python argparse Namespace repr (strings quoted '...' or "...").
std::map<std::string, std::string> parse_namespace(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path, "cannot open file");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string s = ss.str();
  const size_t open = s.find("Namespace(");
  if (open == std::string::npos) throw Error(path, "not a 3DGS cfg_args file (no 'Namespace(')");
  std::map<std::string, std::string> kv;
  size_t i = open + 10;
  while (i < s.size() && s[i] != ')') {
    while (i < s.size() && (s[i] == ' ' || s[i] == ',')) ++i;
    const size_t eq = s.find('=', i);
    if (eq == std::string::npos) break;
    const std::string key = s.substr(i, eq - i);
    i = eq + 1;
    std::string value;
    if (i < s.size() && (s[i] == '\'' || s[i] == '"')) {
      const char q = s[i++];
      while (i < s.size() && s[i] != q) {
        if (s[i] == '\\' && i + 1 < s.size()) ++i;
        value += s[i++];
      }
      ++i;
    } else {
      int depth = 0;
      while (i < s.size() && (depth > 0 || (s[i] != ',' && s[i] != ')'))) {
        if (s[i] == '(' || s[i] == '[') ++depth;
        if (s[i] == ')' || s[i] == ']') --depth;
        value += s[i++];
      }
    }
    kv[key] = value;
  }
  return kv;
}

// The point cloud of the largest iteration, "" if none.
std::string latest_point_cloud(const fs::path& dir) {
  const fs::path pc = dir / "point_cloud";
  if (!fs::is_directory(pc)) return "";
  long best = -1;
  std::string path;
  for (const auto& e : fs::directory_iterator(pc)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("iteration_", 0) != 0) continue;
    const std::string digits = n.substr(10);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    const long it = std::stol(digits);
    const fs::path ply = e.path() / "point_cloud.ply";
    if (it > best && fs::is_regular_file(ply)) best = it, path = ply.string();
  }
  return path;
}

double number(const nlohmann::json& e, const char* key, const std::string& path, const std::string& where) {
  if (!e.contains(key) || !e[key].is_number()) throw Error(path, where + " has no number '" + key + "'");
  return e[key].get<double>();
}

// An image side: a whole number of pixels in [1, 65536] (the Camera's limit).
int image_side(const nlohmann::json& e, const char* key, const std::string& path, const std::string& where) {
  const double v = number(e, key, path, where);
  if (!(v >= 1 && v <= 65536 && v == std::floor(v)))
    throw Error(path, where + " '" + key + "' is " + e[key].dump() + ": an image side is a whole number of 1..65536 pixels");
  return int(v);
}

// A focal length in pixels (finite, > 0) or a principal point coordinate: absent
// is the image centre (INRIA's 3DGS), present is a finite number within ten image
// sides of the centre (Blender's lens shift range), so the view sees its target.
double focal(const nlohmann::json& e, const char* key, const std::string& path, const std::string& where) {
  const double v = number(e, key, path, where);
  if (!(v > 0 && std::isfinite(v) && v < 1e30))
    throw Error(path, where + " '" + key + "' is " + e[key].dump() + ": a focal length is a positive number of pixels");
  return v;
}
double principal(const nlohmann::json& e, const char* key, int side, int longest, const std::string& path,
                 const std::string& where) {
  if (!e.contains(key)) return 0.5 * side;
  if (!e[key].is_number())
    throw Error(path, where + " '" + key + "' is " + e[key].dump() + ", not a number (pixels from the left/top edge)");
  const double v = e[key].get<double>();
  if (!(std::fabs(v - 0.5 * side) <= 10.0 * longest))
    throw Error(path, where + " '" + key + "' is " + e[key].dump() + ": the principal point must lie within ten image " +
                          "sides of the image centre (" + nlohmann::json(0.5 * side).dump() + ")");
  return v;
}

// The lens and pose of one cameras.json entry.
void parse_3dgs_pose(const nlohmann::json& e, const std::string& cams_path, const std::string& where, CaptureView& v) {
  const int w = image_side(e, "width", cams_path, where), h = image_side(e, "height", cams_path, where);
  v.lens.model = "PINHOLE";
  v.lens.width = w;
  v.lens.height = h;
  v.lens.fx = focal(e, "fx", cams_path, where);
  v.lens.fy = focal(e, "fy", cams_path, where);
  // Centred, as INRIA's 3DGS renders; forks that fit an off-centre principal point write cx, cy.
  v.lens.cx = principal(e, "cx", w, std::max(w, h), cams_path, where);
  v.lens.cy = principal(e, "cy", h, std::max(w, h), cams_path, where);
  const auto& pos = e.value("position", nlohmann::json());
  const auto& rot = e.value("rotation", nlohmann::json());
  if (!pos.is_array() || pos.size() != 3 || !rot.is_array() || rot.size() != 3)
    throw Error(cams_path, where + " needs 'position' [3] and 'rotation' [3][3]");
  for (int r = 0; r < 3; ++r) {
    if (!rot[r].is_array() || rot[r].size() != 3 || !pos[r].is_number())
      throw Error(cams_path, where + " needs 'position' [3] and 'rotation' [3][3] of numbers");
    for (int k = 0; k < 3; ++k)
      if (!rot[r][k].is_number()) throw Error(cams_path, where + ".rotation has a non-number");
    // Columns of the rotation are the camera's +x (right), +y (down), +z (forward).
    v.cam_to_world[size_t(r) * 4 + 0] = rot[r][0].get<double>();
    v.cam_to_world[size_t(r) * 4 + 1] = -rot[r][1].get<double>();
    v.cam_to_world[size_t(r) * 4 + 2] = -rot[r][2].get<double>();
    v.cam_to_world[size_t(r) * 4 + 3] = pos[r].get<double>();
  }
}

}  // namespace

std::string layout_gaussians(const std::string& dir) {
  return detect_layout(dir) == "3dgs" ? latest_point_cloud(dir) : std::string();
}

Capture read_3dgs_capture(const std::string& root, const DatasetOptions& o) {
  const fs::path dir(root);
  const std::string cfg_path = (dir / "cfg_args").string(), cams_path = (dir / "cameras.json").string();
  const auto cfg = parse_namespace(cfg_path);
  fs::path source = cfg.count("source_path") ? fs::path(cfg.at("source_path")) : fs::path();
  if (source.empty()) throw Error(cfg_path, "no source_path (the capture the Gaussians were trained on)");
  if (source.is_relative() && !fs::is_directory(source)) source = dir.parent_path() / source;
  if (!fs::is_directory(source))
    throw Error(cfg_path, "source_path '" + cfg.at("source_path") + "' is not a folder here (the capture has moved?)");
  const std::string images = !o.images.empty() ? o.images : cfg.count("images") ? cfg.at("images") : "images";
  const fs::path images_dir = source / images;
  if (!fs::is_directory(images_dir)) throw Error(images_dir.string(), "image folder not found (named by " + cfg_path + ")");
  std::map<std::string, std::string> by_stem;  // cameras.json names images without extension
  for (const auto& e : fs::directory_iterator(images_dir))
    if (e.is_regular_file()) by_stem.emplace(e.path().stem().string(), e.path().string());
  const fs::path masks = fs::is_directory(source / "masks") ? source / "masks" : fs::path();

  const nlohmann::json j = load_json_file(cams_path, "3DGS cameras.json");
  if (!j.is_array() || j.empty()) throw Error(cams_path, "expected a non-empty array of cameras");

  Capture c;
  c.layout = "3dgs";
  c.root = root;
  c.camera_file = cams_path;
  c.images_dir = images_dir.string();
  c.gaussians = latest_point_cloud(dir);
  for (size_t i = 0; i < j.size(); ++i) {
    const auto& e = j[i];
    const std::string where = "camera [" + std::to_string(i) + "]";
    if (!e.is_object() || !e.contains("img_name") || !e["img_name"].is_string())
      throw Error(cams_path, where + " has no 'img_name'");
    CaptureView v;
    v.name = e["img_name"].get<std::string>();
    auto f = by_stem.find(v.name);
    if (f == by_stem.end()) throw Error(cams_path, where + ": no image '" + v.name + ".*' in " + images_dir.string());
    v.image = f->second;
    v.mask = find_mask(masks, fs::path(v.image).filename().string(), v.image);
    parse_3dgs_pose(e, cams_path, where, v);
    c.views.push_back(std::move(v));
  }
  return c;
}

std::vector<Camera> load_3dgs_cameras(const std::string& cams_path) {
  const nlohmann::json j = load_json_file(cams_path, "3DGS cameras.json");
  if (!j.is_array() || j.empty()) throw Error(cams_path, "expected a non-empty array of cameras");
  std::vector<Camera> cams;
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string where = "camera [" + std::to_string(i) + "]";
    if (!j[i].is_object()) throw Error(cams_path, where + " is not an object");
    CaptureView v;
    v.name = j[i].contains("img_name") && j[i]["img_name"].is_string() ? j[i]["img_name"].get<std::string>()
                                                                         : "camera_" + std::to_string(i);
    parse_3dgs_pose(j[i], cams_path, where, v);
    float m[16] = {0};
    for (int k = 0; k < 12; ++k) m[k] = float(v.cam_to_world[size_t(k)]);
    m[15] = 1;
    cams.push_back(make_pinhole_camera(m, float(v.lens.fx), float(v.lens.fy), float(v.lens.cx), float(v.lens.cy),
                                       v.lens.width, v.lens.height, v.name));
  }
  return cams;
}

}  // namespace ptir
