// Training datasets for the inversion: NeRF-synthetic and TensoIR layouts.
//
//   DIR/transforms_<split>.json      cameras (camera_angle_x, frames[].transform_matrix,
//                                    frames[].file_path with or without extension)
//   NeRF-synthetic:  DIR/train/r_0.png            (file_path "./train/r_0")
//   TensoIR:         DIR/train_000/rgba.png       (file_path "./train_000/rgba")
//
// Images: RGBA PNG (8/16-bit, sRGB encoded, alpha = object mask, unassociated as
// PNG stores it) or EXR/HDR (linear; EXR colour is associated with alpha, as EXR
// requires, and is un-premultiplied here). RGB without alpha means "no mask".
//
// Optional per-view ground truth, next to the image:
//   TensoIR (image stem "rgba"/"rgb"):  <view folder>/albedo.png, roughness.png, normal.png
//   otherwise:                          <folder>/<stem>_albedo.png, <stem>_roughness.png,
//                                       <stem>_normal.png (NeRF-synthetic also <stem>_normal_0000.png)
// (.png or .exr). Optional prior maps (albedo/roughness from an external
// estimator) live in a separate folder with the same layout and names
// (prior_dir/train_000/albedo.png, prior_dir/train/r_0_albedo.png).
//
// Albedo maps in 8-bit files are sRGB encoded colour (decoded to linear);
// roughness and normal maps are data (normal = 2 v - 1 for 8-bit files).
// Every error is a ptir::Error naming the file and the problem: missing
// transforms or image files, unreadable images, size mismatches, bad JSON.
#pragma once

#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/scene/camera.h"

namespace ptir {

struct DatasetOptions {
  std::string split = "train";  // reads transforms_<split>.json
  std::string prior_dir;        // folder with prior maps in the dataset's layout ("" = none)
  // Training images are decoded once and kept while their total size stays under
  // this budget; beyond it each use reads the file again (a PNG read costs far
  // less than an iteration).
  size_t cache_bytes = size_t(768) << 20;
};

// The files of one view ("" where absent).
struct ViewFiles {
  std::string image;
  std::string gt_albedo, gt_roughness, gt_normal;
  std::string prior_albedo, prior_roughness;
};

// A training image as the loss uses it.
struct TrainingImage {
  Image rgb;    // 3 channels: linear, straight (un-premultiplied) colour
  Image alpha;  // 1 channel: coverage / object mask in [0, 1] (all ones without alpha)
  bool has_alpha = false;
};

struct DatasetView {
  Camera camera;  // camera.image_path == files.image
  ViewFiles files;
};

class Dataset {
 public:
  std::string root;             // DIR
  std::string transforms_path;  // DIR/transforms_<split>.json
  std::string split;
  int width = 0, height = 0;    // every view has this size
  std::vector<DatasetView> views;

  size_t size() const { return views.size(); }
  std::vector<Camera> cameras() const;

  // The training image of view i (cached within the budget; thread-safe).
  std::shared_ptr<const TrainingImage> target(size_t i) const;
  // Optional maps of view i, or an empty Image (width 0) when the view has none.
  // Albedo: 3 channels linear; roughness: 1 channel; normal: 3 channels in [-1, 1].
  Image gt_albedo(size_t i) const;
  Image gt_roughness(size_t i) const;
  Image gt_normal(size_t i) const;
  Image prior_albedo(size_t i) const;
  Image prior_roughness(size_t i) const;
  bool has_priors() const;  // some view has a prior map

  // Set by load_dataset.
  size_t cache_bytes = 0;

 private:
  mutable std::mutex cache_mutex_;
  mutable std::vector<std::shared_ptr<const TrainingImage>> cache_;
  mutable size_t cached_bytes_ = 0;
};

// Reads the dataset in `dir` (a folder, or a transforms_*.json file whose folder is
// the root and whose name gives the split). Validates everything it can without
// decoding pixels: every image exists and has the camera's size; every optional
// map has the image's size.
std::unique_ptr<Dataset> load_dataset(const std::string& dir, const DatasetOptions& options = {});

// One RGB(A) image as a TrainingImage (see above for the encodings).
TrainingImage read_training_image(const std::string& path);

// An optional map: `channels` = 3 (colour: sRGB-decoded when 8-bit) or 1 (data,
// first channel), `normal` = 3 data channels mapped to [-1, 1] when 8-bit.
Image read_map(const std::string& path, int channels, bool colour, bool normal = false);

}  // namespace ptir
