// The COLMAP layout (dataset.h): DIR/sparse/0/{cameras,images}.{bin,txt} and DIR/images/.
#include <cmath>
#include <filesystem>

#include "ptir/core/error.h"
#include "ptir/scene/colmap_model.h"
#include "ptir/scene/dataset_layouts.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

// masks/ for images/, masks_4/ for images_4/ (falling back to masks/); "" if neither exists.
fs::path masks_dir_for(const fs::path& root, const std::string& images) {
  const std::string suffix = images.rfind("images", 0) == 0 ? images.substr(6) : "";
  for (const fs::path& d : {root / ("masks" + suffix), root / "masks"})
    if (fs::is_directory(d)) return d;
  return {};
}

}  // namespace

Capture read_colmap_capture(const std::string& root, const DatasetOptions& o) {
  const std::string model_dir = find_colmap_model(root);
  if (model_dir.empty()) throw Error(root, "no COLMAP model (expected sparse/0/cameras.bin or cameras.txt)");
  const ColmapModel m = read_colmap_model(model_dir);
  const std::string images = o.images.empty() ? "images" : o.images;
  const fs::path images_dir = fs::path(root) / images;
  if (!fs::is_directory(images_dir))
    throw Error(images_dir.string(), "image folder not found (the COLMAP images; choose another with --images)");
  const fs::path masks = masks_dir_for(root, images);

  Capture c;
  c.layout = "colmap";
  c.root = root;
  c.camera_file = m.images_path;
  c.images_dir = images_dir.string();
  for (const ColmapImage& im : m.images) {
    const ColmapCamera& cam = m.cameras.at(im.camera_id);
    const double qn = std::sqrt(im.q[0] * im.q[0] + im.q[1] * im.q[1] + im.q[2] * im.q[2] + im.q[3] * im.q[3]);
    if (!(qn > 1e-12) || !std::isfinite(qn) || !std::isfinite(im.t[0] + im.t[1] + im.t[2]))
      throw Error(m.images_path, "image " + std::to_string(im.id) + " (" + im.name + ") has a degenerate pose");
    CaptureView v;
    v.name = im.name;
    v.image = (images_dir / im.name).lexically_normal().string();
    v.mask = find_mask(masks, im.name, v.image);
    v.lens = lens_from_colmap(cam.model, cam.params, cam.width, cam.height,
                              m.cameras_path + ": camera " + std::to_string(cam.id));
    v.cam_to_world = cam_to_world_from_colmap(im.q, im.t);
    c.views.push_back(std::move(v));
  }
  return c;
}

}  // namespace ptir
