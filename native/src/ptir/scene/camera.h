// Pinhole cameras: NeRF-synthetic transforms_*.json frames and explicit matrices.
//
// Convention (NeRF / Blender): camera-to-world 4x4; the camera looks down its
// local -z axis, +y is up, +x is right. camera_angle_x is the horizontal field
// of view; pixels are square, so the vertical one follows from the aspect ratio.
// Pixel (0, 0) is the top-left corner of the image.
//
// Intrinsics (real captures): focal lengths fx, fy and principal point cx, cy in
// pixels of the full image, in continuous image coordinates whose origin is the
// top-left CORNER of the top-left pixel (pixel centres at +0.5: COLMAP's,
// nerfstudio's and instant-ngp's convention). Image point (u, v) maps to the
// camera-space direction ((u - cx) / fx, -(v - cy) / fy, -1) (v grows downwards,
// camera +y is up). make_camera derives them from fov_x (fx = fy = W / (2 tan(fov_x/2)),
// centred principal point); make_pinhole_camera takes them as given and sets fov_x
// to the horizontal field of view they imply (for display only).
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
  float fov_x = 0.6911112f;  // radians (horizontal field of view; the rays use fx..cy below)
  int width = 0, height = 0;
  float fx = 0, fy = 0, cx = 0, cy = 0;  // pixels of the full image (see the top); set by make_*camera

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
  // The same camera with a w x h image of the same view: the horizontal field of
  // view and the pixel aspect are kept (fx, fy and cx scale by w / width, cy by
  // h / height). Drops any crop. Throws ptir::Error for a non-positive size.
  Camera resized(int w, int h) const;
};

// Camera from a row-major 4x4 camera-to-world matrix. Throws ptir::Error for a
// non-finite or degenerate matrix, a field of view outside (0, pi) or a bad size.
Camera make_camera(const float cam_to_world_rowmajor[16], float fov_x, int width, int height,
                   const std::string& name = "camera");

// Camera from a row-major camera-to-world matrix (NeRF convention, as make_camera)
// and pinhole intrinsics in pixels (see the top). Throws ptir::Error for
// non-positive focal lengths, non-finite values or a bad size.
Camera make_pinhole_camera(const float cam_to_world_rowmajor[16], float fx, float fy, float cx, float cy, int width,
                           int height, const std::string& name = "camera");

// Reads every frame of a NeRF-synthetic transforms_*.json. Image size: width/height
// when > 0, else the file's "w"/"h" keys, else the header of the first frame's
// image (file_path with or without extension, relative to the JSON's folder).
// Pinhole intrinsics fl_x [fl_y, cx, cy] (instant-ngp / nerfstudio keys, per frame or
// top level, for the file's 'w' x 'h') take precedence over camera_angle_x; a
// distorted lens (non-zero k1..k4, p1, p2) is refused (datasets undistort it).
// Throws ptir::Error("<path>: <problem>") for bad JSON or missing keys.
std::vector<Camera> load_transforms_json(const std::string& path, int width = 0, int height = 0);

// Resolves a NeRF-synthetic file_path ("./train/r_0" or "./train_000/rgba", with or
// without extension) against `folder`: returns the existing file, trying .png, .exr,
// .jpg, .jpeg when there is no extension; "" if none exists.
std::string resolve_image_path(const std::string& folder, const std::string& file_path);

}  // namespace ptir
