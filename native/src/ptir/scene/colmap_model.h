// COLMAP sparse models (cameras, images, points3D) in COLMAP's binary (.bin) and
// text (.txt) formats, as COLMAP 3.x writes them (src/colmap/scene/reconstruction_io).
//
//   cameras:  id, model, width, height, params (model order; lens_model.h)
//   images:   id, qw qx qy qz, tx ty tz (world-to-camera: x_cam = R(q) x_world + t,
//             camera looks down +z, +y down, +x right), camera id, name,
//             2D points (x, y in pixels from the image's top-left corner, point3D id or -1)
//   points3D: id, x y z, r g b, reprojection error (pixels), track (image id, 2D point index)
//
// Errors name the file and the problem (truncated file, bad line, unknown camera
// id, unknown camera model id).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ptir/scene/lens_model.h"

namespace ptir {

struct ColmapCamera {
  uint32_t id = 0;
  std::string model;
  int width = 0, height = 0;
  std::vector<double> params;
};

struct ColmapImage {
  uint32_t id = 0;
  std::array<double, 4> q{};  // qw, qx, qy, qz (world-to-camera rotation)
  std::array<double, 3> t{};  // world-to-camera translation
  uint32_t camera_id = 0;
  std::string name;           // relative to the image folder
  std::vector<Point2d> xy;    // 2D points (filled when observations are read)
  std::vector<int64_t> point3d_id;  // -1: no 3D point
};

struct ColmapPoint {
  uint64_t id = 0;
  std::array<double, 3> xyz{};
  std::array<uint8_t, 3> rgb{};
  double error = 0;  // mean reprojection error in pixels
  std::vector<std::pair<uint32_t, uint32_t>> track;  // (image id, 2D point index)
};

struct ColmapModel {
  std::string dir;                       // the folder holding the files
  std::string cameras_path, images_path, points_path;
  bool binary = true;
  std::map<uint32_t, ColmapCamera> cameras;
  std::vector<ColmapImage> images;       // in file order
  std::vector<ColmapPoint> points;       // only when read with points
};

// The folder of a COLMAP model under `root`: root/sparse/0, root/sparse or root
// itself, the first holding cameras.bin or cameras.txt ("" if none).
std::string find_colmap_model(const std::string& root);

// Reads dir/{cameras,images,points3D}.{bin,txt} (binary preferred when both exist).
// Observations (2D points) and points3D are read only when asked.
ColmapModel read_colmap_model(const std::string& dir, bool with_observations = false, bool with_points = false);

// World-to-camera rotation of a COLMAP quaternion (normalised first), row-major.
std::array<double, 9> colmap_rotation(const std::array<double, 4>& q);

}  // namespace ptir
