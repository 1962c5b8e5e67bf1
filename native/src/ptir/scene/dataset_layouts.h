// Inside the dataset reader (dataset.h): one reader per layout, and what they share.
//
// A real-capture reader (COLMAP, 3DGS output, nerfstudio) returns a Capture:
// every view's image, optional mask, lens (intrinsics for the size its file
// states) and pose in our convention (camera.h: camera-to-world, camera looks
// down -z, +y up). dataset_from_capture does the rest for all of them: the
// split, the actual image sizes (intrinsics scaled to them), undistortion, one
// common image size, and the Dataset.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "ptir/scene/dataset.h"
#include "ptir/scene/lens_model.h"

namespace ptir {

struct ImageHeader {
  int width = 0, height = 0, channels = 0;
};
ImageHeader read_image_header(const std::string& path);
std::string size_text(int w, int h);
// First existing file among base + .png/.exr (either case), "" if none.
std::string first_existing(const std::filesystem::path& base);

struct CaptureView {
  std::string name;   // the image's name in the camera file (split order, messages)
  std::string image;  // resolved path
  std::string mask;   // "" = none
  LensModel lens;     // for lens.width x lens.height (scaled to the image's actual size later)
  std::array<double, 12> cam_to_world{};  // row-major 3x4, our convention (camera.h)
};

struct Capture {
  std::string layout;      // "colmap", "3dgs", "nerfstudio"
  std::string root;        // DIR
  std::string camera_file; // the file the poses came from (messages)
  std::string images_dir;  // the image folder (cache naming)
  std::string gaussians;   // a PLY named by the layout ("" if none)
  std::vector<CaptureView> views;
  // Names of the test views when the layout itself defines the split (nerfstudio's
  // test_filenames); empty = holdout / test_list.
  std::vector<std::string> test_names;
};

std::unique_ptr<Dataset> load_nerf_dataset(const std::string& dir, const DatasetOptions& options);

Capture read_colmap_capture(const std::string& root, const DatasetOptions& options);
Capture read_3dgs_capture(const std::string& root, const DatasetOptions& options);
Capture read_nerfstudio_capture(const std::string& root, const DatasetOptions& options);


std::unique_ptr<Dataset> dataset_from_capture(Capture capture, const DatasetOptions& options);

// Helpers shared by the capture readers.
// Camera-to-world (ours) of a COLMAP world-to-camera pose (quaternion qw..qz, translation).
std::array<double, 12> cam_to_world_from_colmap(const std::array<double, 4>& q, const std::array<double, 3>& t);
// The mask of an image, if any: <root>/<masks dir>/<name> with the image's
// extension, .png, or <name>.png; <image stem>_mask.png beside the image.
std::string find_mask(const std::filesystem::path& masks_dir, const std::string& name, const std::string& image);

}  // namespace ptir
