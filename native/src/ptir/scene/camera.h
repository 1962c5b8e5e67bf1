// Pinhole cameras: NeRF-synthetic transforms_*.json frames and explicit matrices.
//
// Convention (NeRF / Blender): camera-to-world 4x4; the camera looks down its
// local -z axis, +y is up, +x is right. camera_angle_x is the horizontal field
// of view; pixels are square, so the vertical one follows from the aspect ratio.
// Pixel (0, 0) is the top-left corner of the image.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ptir/math/ray.h"
#include "ptir/math/vec.h"

namespace ptir {

struct Camera {
  std::string name;        // e.g. "test_004" from file_path, or "camera"
  std::string image_path;  // resolved image path from file_path ("" if none)
  Affine cam_to_world;     // columns of linear: right, up, back; translation: centre
  float fov_x = 0.6911112f;  // radians
  int width = 0, height = 0;

  // Sub-window of the image: pixels [x0, x0+w) x [y0, y0+h) of the full image.
  int crop_x = 0, crop_y = 0;
  int full_width = 0, full_height = 0;  // 0: no crop (the image is width x height)

  Vec3 centre() const { return cam_to_world.translation; }
  // The same camera restricted to a window of its image (rays unchanged). Throws
  // ptir::Error when the window is empty or outside the image.
  Camera crop(int x0, int y0, int w, int h) const;
  // Index of pixel (x, y) of this (possibly cropped) image in the full image, so a
  // crop draws the same random numbers as the full render.
  uint64_t full_pixel_index(int x, int y) const {
    int fw = full_width > 0 ? full_width : width;
    return uint64_t(y + crop_y) * uint64_t(fw) + uint64_t(x + crop_x);
  }
  // Primary ray through image position (px, py) in pixels (px in [0, width)).
  Ray generate_ray(float px, float py) const;
};

// Camera from a row-major 4x4 camera-to-world matrix. Throws ptir::Error for a
// non-finite or degenerate matrix, a field of view outside (0, pi) or a bad size.
Camera make_camera(const float cam_to_world_rowmajor[16], float fov_x, int width, int height,
                   const std::string& name = "camera");

// Reads every frame of a NeRF-synthetic transforms_*.json. Image size: width/height
// when > 0, else the file's "w"/"h" keys, else the header of the first frame's
// image (file_path with or without extension, relative to the JSON's folder).
// Throws ptir::Error("<path>: <problem>") for bad JSON or missing keys.
std::vector<Camera> load_transforms_json(const std::string& path, int width = 0, int height = 0);

// Resolves a NeRF-synthetic file_path ("./train/r_0" or "./train_000/rgba", with or
// without extension) against `folder`: returns the existing file, trying .png, .exr,
// .jpg, .jpeg when there is no extension; "" if none exists.
std::string resolve_image_path(const std::string& folder, const std::string& file_path);

}  // namespace ptir
