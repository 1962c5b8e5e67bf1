// The nerfstudio / instant-ngp layout (dataset.h): DIR/transforms.json.
//
//   intrinsics   fl_x, fl_y, cx, cy, w, h at the top level or per frame (a frame's
//                keys win); camera_angle_x instead of fl_x; fl_y defaults to fl_x,
//                cx, cy to the image centre
//   distortion   camera_model OPENCV (default; k1..k4 radial in r^2, p1, p2) or
//                OPENCV_FISHEYE (k1..k4); top level or per frame
//   poses        frames[].transform_matrix: camera-to-world, OpenGL axes (ours)
//   images       frames[].file_path relative to DIR; with options.images ("images_4")
//                DIR/<images>/<file name> (nerfstudio's downscale folders)
//   masks        frames[].mask_path (1 = supervised), else masks/ as COLMAP
//   split        test_filenames when present, else holdout / test_list
//   frames       applied_transform (3x4): the map from the COLMAP world the poses
//                came from; dataparser_transforms.json (splatfacto: transform 3x4
//                and scale): the frame its Gaussians (ns-export) live in.
#include <cmath>
#include <filesystem>
#include <set>
#include <fstream>
#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/scene/json_limits.h"
#include "ptir/scene/dataset_layouts.h"

namespace ptir {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Regular files only, a size cap, bounded nesting; trailing junk is an error.
json read_json(const std::string& path) { return load_json_file(path, "dataset JSON file"); }

// A 3x4 (or 4x4) matrix as row-major 3x4.
std::array<double, 12> matrix34(const json& m, const std::string& path, const std::string& what) {
  if (!m.is_array() || (m.size() != 3 && m.size() != 4)) throw Error(path, what + " must be a 3x4 or 4x4 matrix");
  std::array<double, 12> out{};
  for (size_t r = 0; r < 3; ++r) {
    if (!m[r].is_array() || m[r].size() != 4) throw Error(path, what + " must be a 3x4 or 4x4 matrix");
    for (size_t c = 0; c < 4; ++c) {
      if (!m[r][c].is_number()) throw Error(path, what + " has a non-number");
      out[r * 4 + c] = m[r][c].get<double>();
      if (!std::isfinite(out[r * 4 + c])) throw Error(path, what + " has a non-finite entry");
    }
  }
  return out;
}

// a * b for 3x4 affine maps (implicit last row 0 0 0 1).
std::array<double, 12> compose(const std::array<double, 12>& a, const std::array<double, 12>& b) {
  std::array<double, 12> o{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      double s = c == 3 ? a[size_t(r) * 4 + 3] : 0.0;
      for (int k = 0; k < 3; ++k) s += a[size_t(r) * 4 + size_t(k)] * b[size_t(k) * 4 + size_t(c)];
      o[size_t(r) * 4 + size_t(c)] = s;
    }
  return o;
}

std::array<double, 12> inverse(const std::array<double, 12>& m, const std::string& path, const std::string& what) {
  const double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9], i = m[10];
  const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  if (!(std::fabs(det) > 1e-12)) throw Error(path, what + " is singular");
  const double R[9] = {(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det,
                       (f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det,
                       (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det};
  std::array<double, 12> o{};
  for (int r = 0; r < 3; ++r) {
    double t = 0;
    for (int k = 0; k < 3; ++k) {
      o[size_t(r) * 4 + size_t(k)] = R[r * 3 + k];
      t -= R[r * 3 + k] * m[size_t(k) * 4 + 3];
    }
    o[size_t(r) * 4 + 3] = t;
  }
  return o;
}

// The frame's key, else the file's, else `fallback`.
double key(const json& frame, const json& top, const char* k, double fallback) {
  if (frame.contains(k) && frame[k].is_number()) return frame[k].get<double>();
  if (top.contains(k) && top[k].is_number()) return top[k].get<double>();
  return fallback;
}

LensModel frame_lens(const json& fr, const json& top, const std::string& path, const std::string& where) {
  LensModel l;
  const double w = key(fr, top, "w", 0), h = key(fr, top, "h", 0);
  if (!(w >= 1 && h >= 1)) throw Error(path, where + ": no image size ('w', 'h')");
  l.width = int(std::lround(w));
  l.height = int(std::lround(h));
  double fx = key(fr, top, "fl_x", 0);
  if (fx <= 0) {
    const double ax = key(fr, top, "camera_angle_x", 0);
    if (!(ax > 0 && ax < M_PI)) throw Error(path, where + ": no focal length ('fl_x' or 'camera_angle_x')");
    fx = 0.5 * w / std::tan(0.5 * ax);
  }
  l.fx = fx;
  l.fy = key(fr, top, "fl_y", fx);
  l.cx = key(fr, top, "cx", 0.5 * w);
  l.cy = key(fr, top, "cy", 0.5 * h);
  if (!(l.fx > 0 && l.fy > 0)) throw Error(path, where + ": focal lengths must be positive");
  std::string model = "OPENCV";
  for (const json* j : {&fr, &top})
    if (j->contains("camera_model") && (*j)["camera_model"].is_string()) {
      model = (*j)["camera_model"].get<std::string>();
      break;
    }
  l.model = model;
  for (int i = 0; i < 4; ++i) l.k[size_t(i)] = key(fr, top, ("k" + std::to_string(i + 1)).c_str(), 0.0);
  if (model == "OPENCV" || model == "PINHOLE" || model == "SIMPLE_PINHOLE") {
    l.kind = LensModel::Kind::RadialTangential;
    l.p1 = key(fr, top, "p1", 0.0);
    l.p2 = key(fr, top, "p2", 0.0);
  } else if (model == "OPENCV_FISHEYE") {
    l.kind = LensModel::Kind::Fisheye;
  } else {
    throw Error(path, where + ": camera_model '" + model + "' is not supported (OPENCV, OPENCV_FISHEYE)");
  }
  if (!l.distorted()) l.kind = LensModel::Kind::Pinhole;
  return l;
}

// Which world frame the cameras are returned in, and the map into it from transforms.json's.
std::array<double, 12> world_map(const json& top, const fs::path& root, const std::string& path, const DatasetOptions& o) {
  const std::array<double, 12> identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  std::string dp = o.dataparser_transforms;
  if (dp.empty() && fs::exists(root / "dataparser_transforms.json")) dp = (root / "dataparser_transforms.json").string();
  std::string world = o.world;
  if (world == "auto") world = dp.empty() ? "data" : "dataparser";
  if (world == "data") return identity;
  if (world == "colmap") {
    if (!top.contains("applied_transform")) return identity;  // the poses are COLMAP's world already
    return inverse(matrix34(top["applied_transform"], path, "applied_transform"), path, "applied_transform");
  }
  if (world != "dataparser") throw Error(path, "unknown world frame '" + o.world + "' (auto, data, dataparser, colmap)");
  if (dp.empty()) throw Error(root.string(), "no dataparser_transforms.json (splatfacto writes it beside config.yml)");
  const json d = read_json(dp);
  if (!d.contains("transform") || !d.contains("scale") || !d["scale"].is_number())
    throw Error(dp, "expected 'transform' (3x4) and 'scale'");
  std::array<double, 12> m = matrix34(d["transform"], dp, "transform");
  const double s = d["scale"].get<double>();
  if (!(s > 0 && std::isfinite(s))) throw Error(dp, "scale must be positive");
  for (double& v : m) v *= s;  // the poses' rotations are re-normalised by make_pinhole_camera
  return m;
}

std::string resolve_image(const fs::path& root, const std::string& file_path, const std::string& images) {
  if (!images.empty()) return (root / images / fs::path(file_path).filename()).lexically_normal().string();
  const fs::path p = root / file_path;
  if (p.has_extension()) return p.lexically_normal().string();
  const std::string found = resolve_image_path(root.string(), file_path);
  return found.empty() ? p.lexically_normal().string() : found;
}

}  // namespace

Capture read_nerfstudio_capture(const std::string& root_dir, const DatasetOptions& o) {
  const fs::path root(root_dir);
  const std::string path = (root / "transforms.json").string();
  const json top = read_json(path);
  if (!top.is_object() || !top.contains("frames") || !top["frames"].is_array() || top["frames"].empty())
    throw Error(path, "missing or empty array 'frames'");
  const std::array<double, 12> to_world = world_map(top, root, path, o);
  const fs::path masks_dir = fs::is_directory(root / "masks") ? root / "masks" : fs::path();

  Capture c;
  c.layout = "nerfstudio";
  c.root = root_dir;
  c.camera_file = path;
  c.images_dir = (root / (o.images.empty() ? "images" : o.images)).string();
  const json& frames = top["frames"];
  std::set<std::string> names;
  for (size_t f = 0; f < frames.size(); ++f) {
    const json& fr = frames[f];
    const std::string where = "frames[" + std::to_string(f) + "]";
    if (!fr.is_object() || !fr.contains("file_path") || !fr["file_path"].is_string())
      throw Error(path, where + " has no 'file_path'");
    if (!fr.contains("transform_matrix")) throw Error(path, where + " has no 'transform_matrix'");
    CaptureView v;
    v.name = fs::path(fr["file_path"].get<std::string>()).lexically_normal().string();
    if (!names.insert(v.name).second) throw Error(path, where + ".file_path: '" + v.name + "' is listed twice");
    v.image = resolve_image(root, v.name, o.images);
    if (fr.contains("mask_path") && fr["mask_path"].is_string()) {
      const std::string mp = fr["mask_path"].get<std::string>();
      const std::string masks = o.images.rfind("images", 0) == 0 ? "masks" + o.images.substr(6) : std::string();
      v.mask = resolve_image(root, mp, masks);
      if (!fs::is_regular_file(v.mask)) throw Error(path, where + ".mask_path: " + v.mask + " not found");
    } else {
      v.mask = find_mask(masks_dir, fs::path(v.name).filename().string(), v.image);
    }
    v.lens = frame_lens(fr, top, path, where);
    v.cam_to_world = compose(to_world, matrix34(fr["transform_matrix"], path, where + ".transform_matrix"));
    c.views.push_back(std::move(v));
  }
  if (top.contains("test_filenames") && top["test_filenames"].is_array())
    for (const json& n : top["test_filenames"])
      if (n.is_string()) c.test_names.push_back(fs::path(n.get<std::string>()).lexically_normal().string());
  return c;
}

}  // namespace ptir
