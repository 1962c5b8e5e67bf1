// What every real-capture layout shares (dataset_layouts.h): layout detection,
// the train/test split, image sizes, undistortion and the Dataset's cameras.
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "ptir/core/error.h"
#include "ptir/io/photo_exposure.h"
#include "ptir/scene/colmap_model.h"
#include "ptir/scene/dataset_layouts.h"
#include "ptir/scene/undistort.h"

namespace ptir {

namespace fs = std::filesystem;

std::string detect_layout(const std::string& dir) {
  if (!fs::is_directory(dir)) return "";
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string n = e.path().filename().string();
    if (n.rfind("transforms_", 0) == 0 && e.path().extension() == ".json") return "nerf";
  }
  const fs::path root(dir);
  if (fs::exists(root / "cameras.json") && fs::exists(root / "cfg_args")) return "3dgs";
  if (!find_colmap_model(dir).empty()) return "colmap";
  if (fs::exists(root / "transforms.json")) return "nerfstudio";
  return "";
}

std::array<double, 12> cam_to_world_from_colmap(const std::array<double, 4>& q, const std::array<double, 3>& t) {
  // COLMAP: x_cam = R x_world + t, camera +x right, +y down, +z forward. Its centre
  // is C = -R^T t and its axes in the world are the rows of R; ours (camera.h)
  // are right = +x, up = -y, back = -z.
  const std::array<double, 9> R = colmap_rotation(q);
  std::array<double, 12> m{};
  for (int i = 0; i < 3; ++i) {
    const double c = -(R[0 + size_t(i)] * t[0] + R[3 + size_t(i)] * t[1] + R[6 + size_t(i)] * t[2]);
    m[size_t(i) * 4 + 0] = R[0 + size_t(i)];
    m[size_t(i) * 4 + 1] = -R[3 + size_t(i)];
    m[size_t(i) * 4 + 2] = -R[6 + size_t(i)];
    m[size_t(i) * 4 + 3] = c;
  }
  return m;
}

std::string find_mask(const fs::path& masks_dir, const std::string& name, const std::string& image) {
  std::vector<fs::path> tries;
  if (!masks_dir.empty()) {
    tries.push_back(masks_dir / name);
    tries.push_back((masks_dir / name).replace_extension(".png"));
    tries.push_back(masks_dir / (name + ".png"));
  }
  const fs::path img(image);
  tries.push_back(img.parent_path() / (img.stem().string() + "_mask.png"));
  for (const fs::path& p : tries)
    if (fs::is_regular_file(p)) return p.lexically_normal().string();
  return "";
}

namespace {

// Indices of the views in the requested split, in name order.
std::vector<size_t> split_views(const Capture& c, const DatasetOptions& o) {
  std::vector<size_t> order(c.views.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return c.views[a].name < c.views[b].name; });
  if (o.split == "all") return order;
  if (o.split != "train" && o.split != "test")
    throw Error(c.root, "split '" + o.split + "' of a " + c.layout + " capture: use train, test or all");

  std::set<std::string> test;
  std::string rule;
  if (!o.test_list.empty() || !c.test_names.empty()) {
    std::vector<std::string> names = c.test_names;
    std::string source = c.camera_file;
    if (!o.test_list.empty()) {
      names.clear();
      source = o.test_list;
      std::ifstream in(o.test_list);
      if (!in) throw Error(o.test_list, "cannot open the test list");
      std::string line;
      while (std::getline(in, line)) {
        while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
        const size_t first = line.find_first_not_of(" \t");
        if (first == std::string::npos || line[first] == '#') continue;
        names.push_back(line.substr(first));
      }
    }
    std::set<std::string> known;
    for (const CaptureView& v : c.views) known.insert(v.name);
    for (const std::string& n : names) {
      if (!known.count(n)) throw Error(source, "test image '" + n + "' is not among the " + c.camera_file + " images");
      test.insert(n);
    }
    rule = "test list " + source;
  } else if (o.holdout > 0) {
    for (size_t k = 0; k < order.size(); k += size_t(o.holdout)) test.insert(c.views[order[k]].name);
    rule = "every " + std::to_string(o.holdout) + "th image";
  } else if (o.holdout < 0) {
    throw Error(c.root, "holdout must be >= 0, got " + std::to_string(o.holdout));
  }
  std::vector<size_t> out;
  for (size_t i : order)
    if ((test.count(c.views[i].name) > 0) == (o.split == "test")) out.push_back(i);
  if (out.empty())
    throw Error(c.camera_file, "no " + o.split + " views (" + std::to_string(c.views.size()) + " images, test = " +
                                   (rule.empty() ? std::string("none (holdout 0)") : rule) + ")");
  return out;
}

// Camera names: the image file's stem ("images/0001.jpg" -> "0001") when the stems
// are unique in the capture, else the path without extension with '/' -> '_'.
std::vector<std::string> view_names(const Capture& c) {
  std::vector<std::string> stems, paths;
  std::set<std::string> seen;
  bool unique = true;
  for (const CaptureView& v : c.views) {
    const fs::path p(v.name);
    stems.push_back(p.stem().string());
    std::string s = (p.parent_path() / p.stem()).generic_string();
    std::replace(s.begin(), s.end(), '/', '_');
    paths.push_back(s);
    unique = unique && seen.insert(stems.back()).second;
  }
  return unique ? stems : paths;
}

// Every view's lens at its image's actual size, and its pinhole window; for every
// view, so the common size does not depend on the split. One image size for the
// whole capture (the optimiser's assumption): the smallest window, each view's
// window shrunk to it about its own centre (a distorted view's undistorted image
// is made at that window; any other view reads that part of its photo:
// DatasetView::crop_x0, a phone's portrait and landscape photos both read
// as the square in their middle).
// A photo smaller than its camera in the layout's own image folder is a wrong or
// half-copied folder (a downscaled folder is chosen with --images images_N, and
// its intrinsics are then scaled); 3DGS cameras.json records the sizes trained at.
std::vector<PinholeWindow> plan_windows(Capture& c, bool folder_chosen) {
  const size_t n = c.views.size();
  std::vector<PinholeWindow> windows(n);
  std::map<std::string, PinholeWindow> planned;  // views sharing a lens share a plan
  for (size_t i = 0; i < n; ++i) {
    CaptureView& v = c.views[i];
    if (!fs::is_regular_file(v.image)) throw Error(v.image, "image not found (" + c.camera_file + " lists '" + v.name + "')");
    const ImageHeader h = read_image_header(v.image);
    if (!folder_chosen && c.layout != "3dgs" && (h.width < v.lens.width || h.height < v.lens.height))
      throw Error(v.image, "image is " + size_text(h.width, h.height) + ", smaller than its camera in " + c.camera_file +
                               " ('" + v.name + "': " + size_text(v.lens.width, v.lens.height) +
                               "); a downscaled image folder is read with --images images_N");
    if (h.width != v.lens.width || h.height != v.lens.height) {
      const double sx = double(h.width) / v.lens.width, sy = double(h.height) / v.lens.height;
      if (std::fabs(sx - sy) > 0.01 * std::max(sx, sy) + 1.0 / std::min(h.width, h.height))
        throw Error(v.image, "image is " + size_text(h.width, h.height) + " but its camera in " + c.camera_file + " is " +
                                 size_text(v.lens.width, v.lens.height) + " (a different aspect ratio: wrong image folder?)");
      v.lens = v.lens.scaled_to(h.width, h.height);
    }
    const std::string key = v.lens.describe();
    auto it = planned.find(key);
    if (it == planned.end()) it = planned.emplace(key, plan_undistortion(v.lens, v.image)).first;
    windows[i] = it->second;
  }
  int W = windows[0].width, H = windows[0].height;
  for (const PinholeWindow& w : windows) W = std::min(W, w.width), H = std::min(H, w.height);
  for (size_t i = 0; i < n; ++i) {
    PinholeWindow& w = windows[i];
    if (w.width == W && w.height == H) continue;
    const int dx = (w.width - W) / 2, dy = (w.height - H) / 2;
    w.x0 += dx;
    w.y0 += dy;
    w.cx -= dx;
    w.cy -= dy;
    w.width = W;
    w.height = H;
  }

  return windows;
}

// The image and mask files of the picked views: undistorted (cached) where the lens
// is distorted. Each file once (views may share a mask file), in parallel.
std::vector<std::array<std::string, 2>> undistort_views(const Capture& c, const std::vector<size_t>& picked,
                                                        const std::vector<PinholeWindow>& windows, const fs::path& cache) {
  struct Job {
    std::string src, dir, out;
    size_t view;
  };
  std::vector<Job> jobs;
  std::map<std::string, size_t> job_of;
  auto job = [&](const std::string& src, const fs::path& dir, size_t view) {
    const PinholeWindow& w = windows[view];
    const std::string key = src + "|" + dir.string() + "|" + c.views[view].lens.describe() + "|" + std::to_string(w.x0) +
                            " " + std::to_string(w.y0) + " " + std::to_string(w.width) + " " + std::to_string(w.height);
    auto it = job_of.emplace(key, jobs.size()).first;
    if (it->second == jobs.size()) jobs.push_back({src, dir.string(), "", view});
    return it->second;
  };
  std::vector<std::array<size_t, 2>> view_jobs(picked.size(), {SIZE_MAX, SIZE_MAX});
  for (size_t k = 0; k < picked.size(); ++k) {
    const CaptureView& v = c.views[picked[k]];
    if (!v.lens.distorted()) continue;
    view_jobs[k][0] = job(v.image, cache, picked[k]);
    if (!v.mask.empty()) view_jobs[k][1] = job(v.mask, cache / "masks", picked[k]);
  }
  // At most 4 at once: each holds its image twice as float (a 24 MP photo: 600 MB).
  tbb::task_arena arena(std::min(4, tbb::this_task_arena::max_concurrency()));
  arena.execute([&] {
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t j) {
      Job& jb = jobs[j];
      jb.out = undistorted_image(jb.src, c.views[jb.view].lens, windows[jb.view], jb.dir);
    });
  });

  std::vector<std::array<std::string, 2>> files(picked.size());
  for (size_t k = 0; k < picked.size(); ++k) {
    const CaptureView& v = c.views[picked[k]];
    files[k][0] = view_jobs[k][0] != SIZE_MAX ? jobs[view_jobs[k][0]].out : v.image;
    files[k][1] = view_jobs[k][1] != SIZE_MAX ? jobs[view_jobs[k][1]].out : v.mask;
  }
  return files;
}

}  // namespace

std::unique_ptr<Dataset> dataset_from_capture(Capture c, const DatasetOptions& o) {
  if (c.views.empty()) throw Error(c.camera_file, "no images");
  {
    std::set<std::string> seen;
    for (const CaptureView& v : c.views)
      if (!seen.insert(v.name).second) throw Error(c.camera_file, "image '" + v.name + "' appears twice");
  }
  const std::vector<PinholeWindow> windows = plan_windows(c, !o.images.empty());
  // The working size: the photos reduced by the smallest integer factor that brings
  // their long side to o.max_side (scene/view_reduce.h; dataset.h says why 1600).
  const int SW = windows[0].width, SH = windows[0].height;
  std::set<std::string> sizes;  // the photos' own sizes (before any window)
  for (const CaptureView& v : c.views) sizes.insert(size_text(v.lens.width, v.lens.height));
  const int f = o.max_side > 0 ? std::max(1, (std::max(SW, SH) + o.max_side - 1) / o.max_side) : 1;
  const int W = SW / f, H = SH / f;
  const std::vector<size_t> picked = split_views(c, o);
  const std::vector<std::string> names = view_names(c);
  const fs::path cache = !o.undistort_dir.empty() ? fs::path(o.undistort_dir)
                                                  : fs::path(c.root) / "ptir_undistorted" / fs::path(c.images_dir).filename();
  auto data = std::make_unique<Dataset>();
  data->root = c.root;
  data->transforms_path = c.camera_file;
  data->split = o.split;
  data->layout = c.layout;
  data->gaussians_path = c.gaussians;
  data->cache_bytes = o.cache_bytes;
  data->black_background = o.black_background;
  data->width = W;
  data->height = H;
  data->reduce = f;
  data->source_width = SW;
  data->source_height = SH;
  if (sizes.size() > 1) {
    std::string list;
    for (const std::string& t : sizes) list += (list.empty() ? "" : ", ") + t;
    data->size_note = "photos of " + std::to_string(sizes.size()) + " sizes (" + list + "): each read as the " +
                      size_text(SW, SH) + " about its centre";
  }
  if (f > 1)
    data->size_note += (data->size_note.empty() ? "photos " + size_text(SW, SH) : std::string()) + ", read at " +
                       size_text(W, H) + " (1/" + std::to_string(f) + ": --max-image-side " + std::to_string(o.max_side) +
                       ")";
  data->views.resize(picked.size());
  const std::vector<std::array<std::string, 2>> files = undistort_views(c, picked, windows, cache);
  // EXIF exposure of every photo of the capture (train and test share the reference), from the source files.
  std::vector<double> exposure;
  if (o.exif_exposure) {
    std::vector<std::optional<PhotoExposure>> photos(c.views.size());
    tbb::parallel_for(size_t(0), c.views.size(), [&](size_t i) { photos[i] = read_photo_exposure(c.views[i].image); });
    exposure = relative_exposures(photos);
  }
  for (size_t k = 0; k < picked.size(); ++k) {
    const CaptureView& v = c.views[picked[k]];
    const PinholeWindow& w = windows[picked[k]];
    DatasetView& dv = data->views[k];
    dv.files.image = files[k][0];
    dv.files.mask = files[k][1];
    if (!exposure.empty()) dv.exposure = exposure[picked[k]];
    if (!v.lens.distorted() && (w.x0 != 0 || w.y0 != 0 || w.width != v.lens.width || w.height != v.lens.height)) {
      dv.cropped = true;  // the part of the photo this view reads (plan_windows)
      dv.crop_x0 = w.x0;
      dv.crop_y0 = w.y0;
    }
    float m[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
    for (int e = 0; e < 12; ++e) m[e] = float(v.cam_to_world[size_t(e)]);
    try {
      const float r = 1.0f / float(f);  // the working size's pixels (x_reduced = x / f)
      dv.camera = make_pinhole_camera(m, float(w.fx) * r, float(w.fy) * r, float(w.cx) * r, float(w.cy) * r, W, H,
                                      names[picked[k]]);
    } catch (const Error& e) {
      throw Error(c.camera_file, std::string("image '") + v.name + "': " + e.what());
    }
    dv.camera.image_path = dv.files.image;
    if (!o.prior_dir.empty()) {
      const std::string stem = fs::path(v.name).stem().string();
      dv.files.prior_albedo = first_existing(fs::path(o.prior_dir) / (stem + "_albedo"));
      dv.files.prior_roughness = first_existing(fs::path(o.prior_dir) / (stem + "_roughness"));
    }
  }
  if (!o.prior_dir.empty() && !data->has_priors())
    throw Error(o.prior_dir, "no prior maps found for any view (expected e.g. " +
                                 (fs::path(o.prior_dir) / (fs::path(c.views[picked[0]].name).stem().string() + "_albedo.png"))
                                     .string() +
                                 ")");
  return data;
}

}  // namespace ptir
