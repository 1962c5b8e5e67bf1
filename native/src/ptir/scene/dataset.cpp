#include "ptir/scene/dataset.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "ptir/core/error.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool is_alpha_name(const std::string& n) { return n == "A" || n == "a" || lower(n) == "alpha"; }

// First existing file among base + each extension ("" if none).
std::string first_existing(const fs::path& base) {
  for (const char* ext : {".png", ".exr", ".PNG", ".EXR"}) {
    fs::path p = base;
    p += ext;
    if (fs::exists(p)) return p.lexically_normal().string();
  }
  return "";
}

struct Header {
  int width = 0, height = 0, channels = 0;
};

Header read_header(const std::string& path) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(path, "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& s = in->spec();
  if (s.width <= 0 || s.height <= 0 || s.nchannels <= 0) throw Error(path, "image has no pixels");
  return {s.width, s.height, s.nchannels};
}

// Pixels as float, plus whether they are display-encoded (integer formats) and
// which channel is alpha. PNG alpha is read unassociated (as stored).
struct RawImage {
  int width = 0, height = 0, channels = 0, alpha = -1;
  bool integer = false;
  std::vector<float> px;
};

RawImage read_raw(const std::string& path) {
  if (!fs::exists(path)) throw Error(path, "file not found");
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) throw Error(path, "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& s = in->spec();
  if (s.width <= 0 || s.height <= 0 || s.nchannels <= 0) throw Error(path, "image has no pixels");
  RawImage r;
  r.width = s.width;
  r.height = s.height;
  r.channels = s.nchannels;
  r.alpha = s.alpha_channel;
  if (r.alpha < 0)
    for (int c = 0; c < s.nchannels && c < int(s.channelnames.size()); ++c)
      if (is_alpha_name(s.channelnames[c]) && (c == 1 || c == 3)) r.alpha = c;
  const auto base = s.format.basetype;
  r.integer = base != OIIO::TypeDesc::FLOAT && base != OIIO::TypeDesc::HALF && base != OIIO::TypeDesc::DOUBLE;
  r.px.resize(size_t(r.width) * r.height * r.channels);
  if (!in->read_image(0, 0, 0, s.nchannels, OIIO::TypeDesc::FLOAT, r.px.data()))
    throw Error(path, "cannot decode image data: " + in->geterror());
  for (float v : r.px)
    if (!std::isfinite(v)) throw Error(path, "image contains NaN or infinite values");
  return r;
}

// Colour channels of a raw image: indices of R, G, B (grey repeats its channel).
void colour_channels(const RawImage& r, int idx[3]) {
  std::vector<int> colour;
  for (int c = 0; c < r.channels; ++c)
    if (c != r.alpha) colour.push_back(c);
  if (colour.empty()) colour.push_back(0);
  for (int k = 0; k < 3; ++k) idx[k] = colour.size() >= 3 ? colour[size_t(k)] : colour[0];
}

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

}  // namespace

TrainingImage read_training_image(const std::string& path) {
  RawImage r = read_raw(path);
  TrainingImage t;
  t.rgb = Image(r.width, r.height, {"R", "G", "B"});
  t.alpha = Image(r.width, r.height, {"A"});
  t.has_alpha = r.alpha >= 0;
  int idx[3];
  colour_channels(r, idx);
  const size_t n = size_t(r.width) * r.height;
  for (size_t p = 0; p < n; ++p) {
    const float* src = &r.px[p * r.channels];
    float a = t.has_alpha ? std::clamp(src[r.alpha], 0.0f, 1.0f) : 1.0f;
    t.alpha.pixels[p] = a;
    for (int c = 0; c < 3; ++c) {
      float v = src[idx[c]];
      if (r.integer) {
        v = srgb_to_linear(std::clamp(v, 0.0f, 1.0f));  // PNG: straight sRGB colour
      } else {
        v = std::max(v, 0.0f);
        if (t.has_alpha && a > 1e-6f) v /= a;  // EXR: associated alpha -> straight colour
      }
      t.rgb.pixels[p * 3 + c] = v;
    }
  }
  return t;
}

Image read_map(const std::string& path, int channels, bool colour, bool normal) {
  RawImage r = read_raw(path);
  Image out(r.width, r.height, channels == 3 ? std::vector<std::string>{"R", "G", "B"} : std::vector<std::string>{"Y"});
  int idx[3];
  colour_channels(r, idx);
  const size_t n = size_t(r.width) * r.height;
  for (size_t p = 0; p < n; ++p)
    for (int c = 0; c < channels; ++c) {
      float v = r.px[p * r.channels + idx[c]];
      if (r.integer) {
        v = std::clamp(v, 0.0f, 1.0f);
        if (colour) v = srgb_to_linear(v);
        else if (normal) v = 2.0f * v - 1.0f;
      }
      out.pixels[p * channels + c] = v;
    }
  return out;
}

std::vector<Camera> Dataset::cameras() const {
  std::vector<Camera> c;
  c.reserve(views.size());
  for (const DatasetView& v : views) c.push_back(v.camera);
  return c;
}

std::shared_ptr<const TrainingImage> Dataset::target(size_t i) const {
  if (i >= views.size()) throw Error(transforms_path, "view index " + std::to_string(i) + " out of range");
  {
    std::lock_guard<std::mutex> lock(cache_mutex_);
    if (cache_.size() != views.size()) cache_.resize(views.size());
    if (cache_[i]) return cache_[i];
  }
  auto img = std::make_shared<const TrainingImage>(read_training_image(views[i].files.image));
  if (img->rgb.width != width || img->rgb.height != height)
    throw Error(views[i].files.image, "image is " + size_text(img->rgb.width, img->rgb.height) + ", the dataset's views are " +
                                          size_text(width, height));
  const size_t bytes = (img->rgb.pixels.size() + img->alpha.pixels.size()) * sizeof(float);
  std::lock_guard<std::mutex> lock(cache_mutex_);
  if (!cache_[i] && cached_bytes_ + bytes <= cache_bytes) {
    cache_[i] = img;
    cached_bytes_ += bytes;
  }
  return img;
}

namespace {

Image load_optional(const std::string& path, int channels, bool colour, bool normal, int w, int h) {
  if (path.empty()) return Image();
  Image m = read_map(path, channels, colour, normal);
  if (m.width != w || m.height != h)
    throw Error(path, "map is " + size_text(m.width, m.height) + ", the view's image is " + size_text(w, h));
  return m;
}

}  // namespace

Image Dataset::gt_albedo(size_t i) const { return load_optional(views.at(i).files.gt_albedo, 3, true, false, width, height); }
Image Dataset::gt_roughness(size_t i) const {
  return load_optional(views.at(i).files.gt_roughness, 1, false, false, width, height);
}
Image Dataset::gt_normal(size_t i) const { return load_optional(views.at(i).files.gt_normal, 3, false, true, width, height); }
Image Dataset::prior_albedo(size_t i) const {
  return load_optional(views.at(i).files.prior_albedo, 3, true, false, width, height);
}
Image Dataset::prior_roughness(size_t i) const {
  return load_optional(views.at(i).files.prior_roughness, 1, false, false, width, height);
}
bool Dataset::has_priors() const {
  for (const DatasetView& v : views)
    if (!v.files.prior_albedo.empty() || !v.files.prior_roughness.empty()) return true;
  return false;
}

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

std::unique_ptr<Dataset> load_dataset(const std::string& dir, const DatasetOptions& options) {
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
      throw Error(dir, "no transforms_" + split + ".json" + (found.empty() ? std::string(" (no transforms_*.json at all)")
                                                                          : " (found: " + found + ")"));
    }
  }
  data->root = root.string();
  data->split = split;
  data->transforms_path = transforms.string();
  data->cache_bytes = options.cache_bytes;
  if (!options.prior_dir.empty() && !fs::is_directory(options.prior_dir))
    throw Error(options.prior_dir, "prior folder not found");

  // Cameras (validates the JSON); the frames' file_path again, for the messages.
  std::vector<Camera> cams = load_transforms_json(data->transforms_path);
  nlohmann::json j;
  {
    std::ifstream in(data->transforms_path);
    in >> j;
  }
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
    Header h = read_header(cam.image_path);
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
      Header mh = read_header(*m);
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
