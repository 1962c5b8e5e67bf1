// Training datasets for the inversion. load_dataset detects the layout of DIR:
//
//   NeRF-synthetic / TensoIR  DIR/transforms_<split>.json (below)
//   COLMAP                    DIR/sparse/0/{cameras,images,points3D}.{bin,txt} (or DIR/sparse/, DIR/)
//                             + DIR/images/ (or options.images, e.g. "images_4")
//   3DGS output folder        DIR/cameras.json + DIR/cfg_args (source capture, image folder)
//                             + DIR/point_cloud/iteration_N/point_cloud.ply (largest N)
//   nerfstudio / instant-ngp  DIR/transforms.json (one file, every frame; splits by holdout)
//
// Real captures (the last three) have pinhole or distorted lenses; distorted
// images are undistorted once to a pinhole and cached (undistort.h). Their split:
// test = every `holdout`-th image in name order (Mip-NeRF 360 / 3DGS convention,
// 8), or the names in `test_list`; train = the rest. docs/dataset_format.md
// documents every layout, convention and choice.
//
// NeRF-synthetic layouts:
//   DIR/transforms_<split>.json      cameras (camera_angle_x, frames[].transform_matrix,
//                                    frames[].file_path with or without extension)
//   NeRF-synthetic:  DIR/train/r_0.png            (file_path "./train/r_0")
//   TensoIR:         DIR/train_000/rgba.png       (file_path "./train_000/rgba")
//
// Images: RGBA PNG (8/16-bit, sRGB encoded, alpha = object mask, unassociated as
// PNG stores it) or EXR/HDR (linear; EXR colour is associated with alpha, as EXR
// requires, and is un-premultiplied here). RGB without alpha means "no mask":
// every pixel is supervised (unbounded real scenes). A separate mask file (real
// captures: masks/, <name>_mask.png, nerfstudio mask_path) replaces the alpha.
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

#include <array>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <optional>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/material/shading_model.h"
#include "ptir/math/pixel_filter.h"
#include "ptir/scene/camera.h"

namespace ptir {

struct DatasetOptions {
  std::string split = "train";  // NeRF: reads transforms_<split>.json; captures: "train", "test" or "all"
  std::string prior_dir;        // folder with prior maps in the dataset's layout ("" = none)
  std::string layout = "auto";  // auto (detect), nerf, colmap, 3dgs, nerfstudio
  // Real captures.
  std::string images;           // image folder ("" = the layout's: "images", or cfg_args' for 3DGS);
                                // intrinsics are scaled to its images' size (e.g. "images_4")
  int holdout = 8;              // test = every holdout-th image in name order (0: no test views)
  // Real captures: photos whose long side is over this are read reduced by the
  // smallest integer factor that brings it to at most this (box average,
  // scene/view_reduce.h; intrinsics divided by it); 0: as stored. 800: the
  // plush dog's photos upscaled to 3000 x 2000 and read at 750 x 500 score
  // 1.2-1.4 dB higher on the held-out object than at 1500 x 1000 under the
  // same 5-minute budget on 2 cores (docs/captures.md): at a budget, the
  // iterations per pixel are what the albedo converges on.
  int max_side = 800;
  std::string test_list;        // a file of test image names, one per line (overrides holdout)
  std::string undistort_dir;    // cache of undistorted images ("" = DIR/ptir_undistorted/<images>)
  std::string dataparser_transforms;  // nerfstudio: splatfacto's dataparser_transforms.json
                                      // ("" = DIR/dataparser_transforms.json when present)
  std::string world = "auto";   // nerfstudio frame: auto (dataparser when its file is found, else data),
                                // data (transforms.json as written), dataparser, colmap (undo applied_transform)
  bool black_background = false;  // pixels whose colour is exactly 0 are background (mask 0)
  // Real captures whose every photo records EXIF ExposureTime (io/photo_exposure.h):
  // each training image is divided by its exposure relative to the capture's
  // median, so photos taken with different settings agree (false: as stored).
  bool exif_exposure = true;
  // A capture calibration file (scene/capture_calibration.h: the subject's masks, the
  // photos' gains, EXIF on or off), applied after reading ("" = none).
  std::string calibration;
  // Training images are decoded once and kept while their total size stays under
  // this budget; beyond it each use reads the file again (a PNG read costs far
  // less than an iteration).
  size_t cache_bytes = size_t(768) << 20;
};

// The files of one view ("" where absent).
struct ViewFiles {
  std::string image;
  std::string mask;  // separate mask (1 = supervised), "" = the image's alpha or none
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
  double exposure = 1.0;  // EXIF exposure relative to the capture's median (1: none); target() divides by it
  // The camera's white balance and exposure against the capture's consensus, per channel
  // (scene/capture_calibration.h; 1: none); target() divides by it too.
  std::array<float, 3> gain{1.0f, 1.0f, 1.0f};
  // Real captures of several image sizes: the window of its stored photo this view
  // reads (the common size about its centre; width 0: the whole photo).
  int crop_x0 = 0, crop_y0 = 0;
  bool cropped = false;
};

class Dataset {
 public:
  std::string root;             // DIR
  std::string transforms_path;  // DIR/transforms_<split>.json (captures: the camera file read)
  std::string split;
  std::string layout = "nerf";  // "nerf", "colmap", "3dgs", "nerfstudio"
  std::string gaussians_path;   // the PLY the layout names (3DGS: point_cloud/iteration_N), "" if none
  bool black_background = false;
  int width = 0, height = 0;    // every view has this size
  // Real captures: every photo (and a mask at the photo's size) is read reduced
  // by this (DatasetOptions::max_side); source_width x source_height is the size
  // as stored (after undistortion). 1: as stored.
  int reduce = 1;
  int source_width = 0, source_height = 0;
  std::string size_note;  // what the loader did to the photos' sizes ("" when nothing): the log's line
  std::vector<DatasetView> views;
  // The pixel filter its images were rendered with, from DIR/dataset.json
  // ("cycles": {"pixel_filter": {"type": "box", "width": 1.0}}, or the older text
  // "box 1px"); unset when the dataset does not say (photographs, other makers).
  std::optional<PixelFilter> pixel_filter;
  // The surface model its images were rendered with: "ptir_brdf" of its
  // transforms_<split>.json ("principled-v1" for Cycles 3.x, "principled-v2" for 4.x+,
  // as scripts/make_dataset.py writes it) or of DIR/dataset.json (every layout);
  // unset when neither says.
  std::optional<BsdfModel> brdf;
  // The applied capture calibration's record (JSON text; "" = none): OUT/settings.json's "capture".
  std::string calibration_record;

  size_t size() const { return views.size(); }
  std::vector<Camera> cameras() const;

  // The training image of view i (cached within the budget; thread-safe).
  std::shared_ptr<const TrainingImage> target(size_t i) const;
  // Every view's photo (and mask) decoded whole and checked against the
  // dataset's size, before a job starts: a corrupt or mismatched photo is an
  // error naming it before the first iteration (and checkpoint), not when its
  // view is first drawn. The decoded images stay in the cache while they fit.
  void check_images() const;
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

// The filter to render a dataset's views with: the dataset's own when it records
// one (DIR/dataset.json), else Blender's default (Blackman-Harris, 1.5 px).
PixelFilter dataset_pixel_filter(const Dataset& data);

// "ptir_brdf" of a transforms_*.json (a NeRF-layout camera file): unset when absent;
// an unknown name is an error naming the file.
std::optional<BsdfModel> read_recorded_bsdf_model(const std::string& transforms_path);

// The model a command renders with when --brdf is not given: the scene file's "brdf"
// when it names one (scene_named), else the dataset's recorded one, else kDefaultBsdfModel.
BsdfModel resolve_bsdf_model(bool scene_named, BsdfModel scene_model, std::optional<BsdfModel> recorded);

// One RGB(A) image as a TrainingImage (see above for the encodings). With a mask
// file, its first channel (8/16-bit: v / max; float: as is), clamped to [0, 1],
// is the alpha; black_background sets alpha 0 where every colour channel is 0.
// The part of a stored photo a view reads: the window [x0, x0 + width) x [y0, y0 +
// height) (width 0: the whole photo), then box-averaged by `reduce`
// (scene/view_reduce.h).
struct ReadWindow {
  int x0 = 0, y0 = 0, width = 0, height = 0;
  int reduce = 1;
};

// With a window, the image (and a mask at the image's size) is cropped to it and
// reduced; a mask already at the working size (the window's / reduce) is used as it is.
TrainingImage read_training_image(const std::string& path, const std::string& mask_path = "", bool black_background = false,
                                  const ReadWindow& window = {});

// The layout load_dataset would read in `dir` with layout "auto": "nerf",
// "colmap", "3dgs", "nerfstudio", or "" when none is recognised. Order: a
// transforms_<split>.json makes it NeRF; else cameras.json + cfg_args a 3DGS
// output; else a COLMAP model (sparse/0, sparse or DIR itself); else transforms.json.
std::string detect_layout(const std::string& dir);

// The trained Gaussians a dataset folder names: for a 3DGS output folder
// point_cloud/iteration_N/point_cloud.ply of the largest N; "" otherwise.
std::string layout_gaussians(const std::string& dir);

// Every camera of a 3DGS output folder's cameras.json (dataset_3dgs.cpp's
// conventions), without the images: the poses of a capture for targets rendered
// from the splats themselves (`optimize` without --dataset). Errors name the file.
std::vector<Camera> load_3dgs_cameras(const std::string& cameras_json);

// An optional map: `channels` = 3 (colour: sRGB-decoded when 8-bit) or 1 (data,
// first channel), `normal` = 3 data channels mapped to [-1, 1] when 8-bit.
Image read_map(const std::string& path, int channels, bool colour, bool normal = false);

}  // namespace ptir
