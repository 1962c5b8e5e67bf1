#include "ptir/scene/dataset.h"
#include "ptir/scene/view_reduce.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <regex>
#include <fstream>
#include <nlohmann/json.hpp>

#include "ptir/core/error.h"
#include "ptir/scene/capture_calibration.h"
#include "ptir/io/exr_header.h"
#include "ptir/io/input_file.h"
#include "ptir/io/memory_budget.h"
#include "ptir/scene/json_limits.h"
#include "ptir/scene/dataset_layouts.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool is_alpha_name(const std::string& n) { return n == "A" || n == "a" || lower(n) == "alpha"; }

}  // namespace

std::string first_existing(const fs::path& base) {
  for (const char* ext : {".png", ".exr", ".PNG", ".EXR"}) {
    fs::path p = base;
    p += ext;
    if (fs::exists(p)) return p.lexically_normal().string();
  }
  return "";
}


ImageHeader read_image_header(const std::string& path) {
  io::check_exr_header(path, io::check_regular_file(path, "image"));
  auto in = OIIO::ImageInput::open(path);
  if (!in) throw Error(path, "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& s = in->spec();
  if (s.width <= 0 || s.height <= 0 || s.nchannels <= 0) throw Error(path, "image has no pixels");
  return {s.width, s.height, s.nchannels};
}

namespace {

// Pixels as float, plus whether they are display-encoded (integer formats) and
// which channel is alpha. PNG alpha is read unassociated (as stored).
struct RawImage {
  int width = 0, height = 0, channels = 0, alpha = -1;
  bool integer = false;
  std::vector<float> px;
};

RawImage read_raw(const std::string& path) {
  io::check_regular_file(path, "image");  // "file not found"; a FIFO or a device refused at once
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) throw Error(path, "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec& s = in->spec();
  if (s.width <= 0 || s.height <= 0 || s.nchannels <= 0) throw Error(path, "image has no pixels");
  io::check_decode_size(path, s.width, s.height, s.nchannels);  // before allocating
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

}  // namespace

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

namespace {

Image crop_to(const Image& img, int x0, int y0, int w, int h) {
  Image out(w, h, img.channel_names);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < img.channels; ++c) out.at(x, y, c) = img.at(x0 + x, y0 + y, c);
  return out;
}

}  // namespace

TrainingImage read_training_image(const std::string& path, const std::string& mask_path, bool black_background,
                                  const ReadWindow& window) {
  const int reduce = std::max(1, window.reduce);
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
  // A separate mask replaces the alpha: its first channel, as stored (integer
  // formats are read as v / max by OIIO), 1 = supervised. At the photo's size it is
  // applied before the reduction, at the reduced size after it.
  RawImage m;
  if (!mask_path.empty()) m = read_raw(mask_path);
  const bool mask_full = !mask_path.empty() && m.width == r.width && m.height == r.height;
  const bool crop = window.width > 0 && (window.width != r.width || window.height != r.height);
  if (crop && (window.x0 < 0 || window.y0 < 0 || window.x0 + window.width > r.width || window.y0 + window.height > r.height))
    throw Error(path, "image is " + size_text(r.width, r.height) + ", smaller than the window " +
                          size_text(window.width, window.height) + " the capture reads");
  const int rw = (crop ? window.width : r.width) / reduce, rh = (crop ? window.height : r.height) / reduce;
  const bool resized = crop || reduce > 1;
  if (!mask_path.empty() && !mask_full && !(resized && m.width == rw && m.height == rh))
    throw Error(mask_path, "mask is " + size_text(m.width, m.height) + ", its image " + path + " is " +
                               size_text(r.width, r.height) + (resized ? " (read at " + size_text(rw, rh) + ")" : ""));
  if (mask_full) {
    for (size_t p = 0; p < n; ++p) t.alpha.pixels[p] = std::clamp(m.px[p * m.channels], 0.0f, 1.0f);
    t.has_alpha = true;
  }
  if (black_background) {
    // Pre-masked photos on black: exactly-black pixels are background.
    for (size_t p = 0; p < n; ++p) {
      const float* c = &t.rgb.pixels[p * 3];
      if (c[0] == 0.0f && c[1] == 0.0f && c[2] == 0.0f) t.alpha.pixels[p] = 0.0f;
    }
    t.has_alpha = true;
  }
  if (crop) {
    t.rgb = crop_to(t.rgb, window.x0, window.y0, window.width, window.height);
    t.alpha = crop_to(t.alpha, window.x0, window.y0, window.width, window.height);
  }
  if (reduce > 1) t = reduce_training_image(t, reduce);
  if (!mask_path.empty() && !mask_full) {
    for (size_t p = 0; p < t.alpha.pixels.size(); ++p) t.alpha.pixels[p] = std::clamp(m.px[p * m.channels], 0.0f, 1.0f);
    t.has_alpha = true;
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
  auto read = std::make_shared<TrainingImage>(
      read_training_image(views[i].files.image, views[i].files.mask, black_background,
                          ReadWindow{views[i].crop_x0, views[i].crop_y0, views[i].cropped ? source_width : 0,
                                     views[i].cropped ? source_height : 0, reduce}));
  const std::array<float, 3>& gain = views[i].gain;
  if (views[i].exposure != 1.0 || gain != std::array<float, 3>{1.0f, 1.0f, 1.0f}) {
    // EXIF exposure (DatasetOptions::exif_exposure) and the calibration's gain.
    const int nc = read->rgb.channels;
    for (size_t p = 0; p < read->rgb.pixels.size(); ++p)
      read->rgb.pixels[p] *= float(1.0 / (views[i].exposure * double(gain[p % size_t(nc) < 3 ? p % size_t(nc) : 0])));
  }
  std::shared_ptr<const TrainingImage> img = read;
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

void Dataset::check_images() const {
  for (size_t i = 0; i < views.size(); ++i) target(i);
}

namespace {

// A map at the photos' stored size is reduced with them (Dataset::reduce).
Image load_optional(const std::string& path, int channels, bool colour, bool normal, int w, int h, int reduce,
                    int source_w, int source_h) {
  if (path.empty()) return Image();
  Image m = read_map(path, channels, colour, normal);
  if (reduce > 1 && m.width == source_w && m.height == source_h) m = reduce_image(m, reduce);
  if (m.width != w || m.height != h)
    throw Error(path, "map is " + size_text(m.width, m.height) + ", the view's image is " + size_text(w, h));
  return m;
}

}  // namespace

Image Dataset::gt_albedo(size_t i) const {
  return load_optional(views.at(i).files.gt_albedo, 3, true, false, width, height, reduce, source_width, source_height);
}
Image Dataset::gt_roughness(size_t i) const {
  return load_optional(views.at(i).files.gt_roughness, 1, false, false, width, height, reduce, source_width, source_height);
}
Image Dataset::gt_normal(size_t i) const {
  return load_optional(views.at(i).files.gt_normal, 3, false, true, width, height, reduce, source_width, source_height);
}
Image Dataset::prior_albedo(size_t i) const {
  return load_optional(views.at(i).files.prior_albedo, 3, true, false, width, height, reduce, source_width, source_height);
}
Image Dataset::prior_roughness(size_t i) const {
  return load_optional(views.at(i).files.prior_roughness, 1, false, false, width, height, reduce, source_width, source_height);
}
bool Dataset::has_priors() const {
  for (const DatasetView& v : views)
    if (!v.files.prior_albedo.empty() || !v.files.prior_roughness.empty()) return true;
  return false;
}

namespace {

// The "pixel_filter" that DIR/dataset.json records under "cycles" (see dataset.h);
// no file or no entry: unset. A malformed entry is an error naming the file.
std::optional<PixelFilter> read_dataset_filter(const fs::path& root) {
  const fs::path meta = root / "dataset.json";
  if (!fs::exists(meta)) return std::nullopt;
  const nlohmann::json j = load_json_file(meta.string(), "dataset.json");
  if (!j.is_object() || !j.contains("cycles") || !j["cycles"].is_object() || !j["cycles"].contains("pixel_filter"))
    return std::nullopt;
  const nlohmann::json& f = j["cycles"]["pixel_filter"];
  try {
    if (f.is_string() && f.get<std::string>() == "box 1px") return PixelFilter{PixelFilterType::Box, 1.0f};
    if (f.is_object() && f.contains("type") && f["type"].is_string() && f.contains("width") && f["width"].is_number()) {
      PixelFilter pf{parse_pixel_filter(f["type"].get<std::string>()), f["width"].get<float>()};
      PixelFilterSampler check(pf);  // validates the width
      return pf;
    }
  } catch (const Error& e) {
    throw Error(meta.string(), std::string("cycles.pixel_filter: ") + e.what());
  }
  throw Error(meta.string(), "cycles.pixel_filter must be {\"type\": \"blackman_harris\"|\"gaussian\"|\"box\", \"width\": pixels}");
}

}  // namespace

PixelFilter dataset_pixel_filter(const Dataset& data) { return data.pixel_filter.value_or(PixelFilter{}); }

namespace {

// The model a record names: its "ptir_brdf", else the Blender of its "generator"
// ("... (Blender 3.4.1, Cycles)", as older sets of the dataset maker name only their
// maker): before 4.0 Principled v1, from 4.0 on v2. Unset when it says neither.
std::optional<BsdfModel> recorded_model(const nlohmann::json& j, const std::string& path) {
  if (!j.is_object()) return std::nullopt;
  if (j.contains("ptir_brdf")) {
    const nlohmann::json& v = j["ptir_brdf"];
    std::optional<BsdfModel> m = v.is_string() ? parse_bsdf_model(v.get<std::string>()) : std::nullopt;
    if (!m) throw Error(path, std::string("ptir_brdf must be one of ") + bsdf_model_names() + ", got " + v.dump());
    return m;
  }
  if (!j.contains("generator") || !j["generator"].is_string()) return std::nullopt;
  const std::string g = j["generator"].get<std::string>();
  std::smatch m;
  if (!std::regex_search(g, m, std::regex(R"(Blender (\d{1,3})\.\d+)"))) return std::nullopt;
  return std::stoi(m[1].str()) < 4 ? BsdfModel::PrincipledV1 : BsdfModel::PrincipledV2;
}

std::optional<nlohmann::json> read_json_record(const fs::path& path) {
  if (!fs::is_regular_file(path)) return std::nullopt;
  try {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw Error(path.string(), std::string("not valid JSON: ") + e.what());
  }
}

}  // namespace

std::optional<BsdfModel> read_recorded_bsdf_model(const std::string& transforms_path) {
  if (fs::path(transforms_path).extension() != ".json") return std::nullopt;
  if (auto j = read_json_record(transforms_path))
    if (auto m = recorded_model(*j, transforms_path)) return m;
  // The dataset maker's dataset.json beside the camera file.
  const fs::path meta = fs::path(transforms_path).parent_path() / "dataset.json";
  if (auto j = read_json_record(meta)) return recorded_model(*j, meta.string());
  return std::nullopt;
}

BsdfModel resolve_bsdf_model(bool scene_named, BsdfModel scene_model, std::optional<BsdfModel> recorded) {
  if (scene_named) return scene_model;
  return recorded.value_or(kDefaultBsdfModel);
}

namespace {

std::unique_ptr<Dataset> load_layout(const std::string& dir, const DatasetOptions& options) {
  if (!options.prior_dir.empty() && !fs::is_directory(options.prior_dir))
    throw Error(options.prior_dir, "prior folder not found");
  std::string layout = options.layout;
  if (layout == "auto") layout = fs::is_regular_file(dir) ? "nerf" : detect_layout(dir);
  if (layout == "nerf" || layout.empty()) return load_nerf_dataset(dir, options);  // "": its errors say what is missing
  if (layout == "colmap") return dataset_from_capture(read_colmap_capture(dir, options), options);
  if (layout == "3dgs") return dataset_from_capture(read_3dgs_capture(dir, options), options);
  if (layout == "nerfstudio") return dataset_from_capture(read_nerfstudio_capture(dir, options), options);
  throw Error(dir, "unknown dataset layout '" + options.layout + "' (auto, nerf, colmap, 3dgs, nerfstudio)");
}

}  // namespace

std::unique_ptr<Dataset> load_dataset(const std::string& dir, const DatasetOptions& options) {
  std::unique_ptr<Dataset> data;
  try {
    data = load_layout(dir, options);
  } catch (const fs::filesystem_error& e) {
    // A path the file system refuses (e.g. a file name in a camera file past
    // NAME_MAX, found by fuzz_nerfstudio): an error naming it, never an escape.
    throw Error(e.path1().empty() ? dir : e.path1().string(), std::string("cannot read the dataset: ") + e.code().message());
  }
  data->pixel_filter = read_dataset_filter(data->root);
  // The surface model the images were rendered with: a NeRF set's camera file or the
  // dataset.json beside it; a capture's DIR/dataset.json (a set converted to COLMAP or
  // nerfstudio keeps its record, scripts/nerf_to_colmap.py), as the pixel filter above.
  // The same record gives the same defaults in every layout (issue 38).
  data->brdf = data->layout == "nerf" ? read_recorded_bsdf_model(data->transforms_path)
                                      : read_recorded_bsdf_model((fs::path(data->root) / "dataset.json").string());
  if (!options.calibration.empty())
    apply_capture_calibration(*data, read_capture_calibration(options.calibration), options.calibration);
  return data;
}

}  // namespace ptir
