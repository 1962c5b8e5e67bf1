// The NeRF-synthetic and TensoIR layouts (dataset.h): DIR/transforms_<split>.json.
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/scene/json_limits.h"
#include "ptir/scene/dataset_layouts.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

// The optional maps of an image in `folder` (relative folder `rel` inside the root),
// looked up under `base` (the dataset root, or the prior folder).
std::string find_map(const fs::path& base, const fs::path& rel, const std::string& stem, const std::string& kind) {
  const bool tensoir = stem == "rgba" || stem == "rgb";
  if (tensoir) return first_existing(base / rel / kind);
  std::string f = first_existing(base / rel / (stem + "_" + kind));
  if (f.empty() && kind == "normal") f = first_existing(base / rel / (stem + "_normal_0000"));
  return f;
}

}  // namespace

std::unique_ptr<Dataset> load_nerf_dataset(const std::string& dir, const DatasetOptions& options) {
  auto data = std::make_unique<Dataset>();
  fs::path root(dir), transforms;
  std::string split = options.split;
  if (fs::is_regular_file(root)) {
    transforms = root;
    root = root.parent_path();
    std::string stem = transforms.stem().string();
    if (stem.rfind("transforms_", 0) == 0) split = stem.substr(11);
  } else {
    if (!fs::is_directory(root)) throw Error(dir, "dataset folder not found");
    transforms = root / ("transforms_" + split + ".json");
    if (!fs::exists(transforms)) {
      std::string found;
      for (const auto& e : fs::directory_iterator(root)) {
        std::string n = e.path().filename().string();
        if (n.rfind("transforms_", 0) == 0 && e.path().extension() == ".json") found += (found.empty() ? "" : ", ") + n;
      }
      const std::string none =
          " (no transforms_*.json at all; nor a COLMAP sparse/0 model, a 3DGS output's cameras.json + cfg_args or a "
          "nerfstudio transforms.json)";
      throw Error(dir, "no transforms_" + split + ".json" + (found.empty() ? none : " (found: " + found + ")"));
    }
  }
  data->root = root.string();
  data->split = split;
  data->transforms_path = transforms.string();
  data->cache_bytes = options.cache_bytes;
  data->black_background = options.black_background;

  // Cameras (validates the JSON); the frames' file_path again, for the messages.
  std::vector<Camera> cams = load_transforms_json(data->transforms_path);
  const nlohmann::json j = load_json_file(data->transforms_path, "transforms file");
  const auto& frames = j["frames"];
  bool any_prior = false;
  for (size_t f = 0; f < cams.size(); ++f) {
    const std::string where = "frames[" + std::to_string(f) + "]";
    const auto& fr = frames[f];
    if (!fr.contains("file_path") || !fr["file_path"].is_string())
      throw Error(data->transforms_path, where + " has no 'file_path' (a training view needs an image)");
    const std::string file_path = fr["file_path"].get<std::string>();
    Camera& cam = cams[f];
    if (cam.image_path.empty())
      throw Error(data->transforms_path, where + ".file_path '" + file_path + "': image not found (tried " +
                                             (root / file_path).lexically_normal().string() +
                                             (fs::path(file_path).has_extension() ? "" : " with .png, .exr, .jpg, .jpeg") + ")");
    ImageHeader h = read_image_header(cam.image_path);
    if (h.width != cam.width || h.height != cam.height)
      throw Error(cam.image_path, "image is " + size_text(h.width, h.height) + " but " +
                                      (f == 0 ? std::string("transforms 'w'/'h' say ") : "the first view is ") +
                                      size_text(cam.width, cam.height));
    if (f == 0) {
      data->width = cam.width;
      data->height = cam.height;
    } else if (cam.width != data->width || cam.height != data->height) {
      throw Error(cam.image_path, "image is " + size_text(cam.width, cam.height) + ", the first view is " +
                                      size_text(data->width, data->height));
    }
    DatasetView v;
    v.camera = cam;
    v.files.image = cam.image_path;
    fs::path img(cam.image_path);
    fs::path rel = fs::relative(img.parent_path(), root);
    std::string stem = img.stem().string();
    v.files.gt_albedo = find_map(root, rel, stem, "albedo");
    v.files.gt_roughness = find_map(root, rel, stem, "roughness");
    v.files.gt_normal = find_map(root, rel, stem, "normal");
    if (!options.prior_dir.empty()) {
      v.files.prior_albedo = find_map(options.prior_dir, rel, stem, "albedo");
      v.files.prior_roughness = find_map(options.prior_dir, rel, stem, "roughness");
      any_prior = any_prior || !v.files.prior_albedo.empty() || !v.files.prior_roughness.empty();
    }
    for (const std::string* m : {&v.files.gt_albedo, &v.files.gt_roughness, &v.files.gt_normal, &v.files.prior_albedo,
                                 &v.files.prior_roughness}) {
      if (m->empty()) continue;
      ImageHeader mh = read_image_header(*m);
      if (mh.width != cam.width || mh.height != cam.height)
        throw Error(*m, "map is " + size_text(mh.width, mh.height) + ", the view's image " + cam.image_path + " is " +
                            size_text(cam.width, cam.height));
    }
    data->views.push_back(std::move(v));
  }
  if (!options.prior_dir.empty() && !any_prior)
    throw Error(options.prior_dir, "no prior maps found for any view (expected e.g. " +
                                       (fs::path(options.prior_dir) /
                                        fs::relative(fs::path(data->views[0].files.image).parent_path(), root) /
                                        (fs::path(data->views[0].files.image).stem() == "rgba" ? "albedo.png"
                                                                                               : fs::path(data->views[0].files.image).stem().string() + "_albedo.png"))
                                           .lexically_normal()
                                           .string() +
                                       ")");
  return data;
}

}  // namespace ptir
