#include "ptir/scene/undistort.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <vector>

#include "ptir/core/fnv1a.h"
#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/memory_budget.h"

namespace ptir {

namespace fs = std::filesystem;

PinholeWindow plan_undistortion(const LensModel& lens, const std::string& where) {
  PinholeWindow w;
  w.fx = lens.fx;
  w.fy = lens.fy;
  const int W = lens.width, H = lens.height;
  if (!lens.distorted()) {
    w.cx = lens.cx;
    w.cy = lens.cy;
    w.width = W;
    w.height = H;
    return w;
  }
  // Undistorted pinhole position (pixels, same intrinsics) of a source image point.
  auto pinhole = [&](double u, double v) {
    const Point2d x = lens.camera_from_image({u, v});
    if (!std::isfinite(x[0]) || !std::isfinite(x[1]))
      throw Error(where, "the " + lens.model + " lens cannot be inverted at image point (" + std::to_string(u) + ", " +
                             std::to_string(v) + "); its distortion is not invertible inside the image");
    return Point2d{lens.fx * x[0] + lens.cx, lens.fy * x[1] + lens.cy};
  };
  double left = -std::numeric_limits<double>::infinity(), right = std::numeric_limits<double>::infinity();
  double top = left, bottom = right;
  for (int y = 0; y < H; ++y) {
    left = std::max(left, pinhole(0.5, y + 0.5)[0]);
    right = std::min(right, pinhole(W - 0.5, y + 0.5)[0]);
  }
  for (int x = 0; x < W; ++x) {
    top = std::max(top, pinhole(x + 0.5, 0.5)[1]);
    bottom = std::min(bottom, pinhole(x + 0.5, H - 0.5)[1]);
  }
  // Wide lenses: at most one image size on either side of the principal point.
  left = std::max(left, lens.cx - W);
  right = std::min(right, lens.cx + W);
  top = std::max(top, lens.cy - H);
  bottom = std::min(bottom, lens.cy + H);
  const double eps = 1e-6;  // a border exactly on a pixel centre stays in
  w.x0 = int(std::ceil(left - 0.5 - eps));
  w.y0 = int(std::ceil(top - 0.5 - eps));
  w.width = int(std::floor(right + 0.5 + eps)) - w.x0;
  w.height = int(std::floor(bottom + 0.5 + eps)) - w.y0;
  if (w.width < 1 || w.height < 1)
    throw Error(where, "undistorting the " + lens.model + " image leaves no pixels (" + lens.describe() + ")");
  w.cx = lens.cx - w.x0;
  w.cy = lens.cy - w.y0;
  return w;
}

namespace {


std::string cache_key(const std::string& src, const LensModel& lens, const PinholeWindow& w) {
  std::error_code ec;
  const auto size = fs::file_size(src, ec);
  const auto time = fs::last_write_time(src, ec).time_since_epoch().count();
  char b[128];
  std::snprintf(b, sizeof b, "|%d %d %d %d|%llu|%lld|v1", w.x0, w.y0, w.width, w.height, (unsigned long long)size,
                (long long)time);
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx",
                (unsigned long long)fnv1a(fs::absolute(src).lexically_normal().string() + "|" + lens.describe() + b));
  return hex;
}

}  // namespace

std::string undistorted_image(const std::string& src, const LensModel& lens, const PinholeWindow& w,
                              const std::string& cache_dir) {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(src, &config);
  if (!in) throw Error(src, "cannot read image: " + OIIO::geterror());
  const OIIO::ImageSpec spec = in->spec();
  if (spec.width != lens.width || spec.height != lens.height)
    throw Error(src, "image is " + std::to_string(spec.width) + "x" + std::to_string(spec.height) + ", its camera is " +
                         std::to_string(lens.width) + "x" + std::to_string(lens.height));
  io::check_decode_size(src, spec.width, spec.height, spec.nchannels);  // before allocating
  const auto base = spec.format.basetype;
  const bool is_float = base == OIIO::TypeDesc::FLOAT || base == OIIO::TypeDesc::HALF || base == OIIO::TypeDesc::DOUBLE;
  const OIIO::TypeDesc out_type = is_float ? OIIO::TypeDesc::FLOAT
                                  : (base == OIIO::TypeDesc::UINT16 || base == OIIO::TypeDesc::INT16) ? OIIO::TypeDesc::UINT16
                                                                                                        : OIIO::TypeDesc::UINT8;
  const fs::path out_path = fs::path(cache_dir) / (fs::path(src).stem().string() + "." + cache_key(src, lens, w) +
                                                   (is_float ? ".exr" : ".png"));
  if (fs::exists(out_path)) return out_path.string();

  const int W = spec.width, H = spec.height, nc = spec.nchannels;
  std::vector<float> px(size_t(W) * H * nc);
  if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, px.data()))
    throw Error(src, "cannot decode image data: " + in->geterror());
  in->close();

  // Output pixel (i, j) has its centre at (x0 + i + 0.5, y0 + j + 0.5) in the
  // uncropped pinhole image; its source point is the lens image of that ray.
  std::vector<float> out(size_t(w.width) * w.height * nc);
  for (int j = 0; j < w.height; ++j)
    for (int i = 0; i < w.width; ++i) {
      const Point2d x{(w.x0 + i + 0.5 - lens.cx) / lens.fx, (w.y0 + j + 0.5 - lens.cy) / lens.fy};
      const Point2d s = lens.image_from_camera(x);
      // Bilinear between pixel centres (index space = position - 0.5), clamped at the edges.
      const double fx = std::clamp(s[0] - 0.5, 0.0, double(W - 1)), fy = std::clamp(s[1] - 0.5, 0.0, double(H - 1));
      const int ix = std::min(int(fx), W - 2 < 0 ? 0 : W - 2), iy = std::min(int(fy), H - 2 < 0 ? 0 : H - 2);
      const int ix1 = std::min(ix + 1, W - 1), iy1 = std::min(iy + 1, H - 1);
      const float ax = float(fx - ix), ay = float(fy - iy);
      float* o = &out[(size_t(j) * w.width + i) * nc];
      const float* p00 = &px[(size_t(iy) * W + ix) * nc];
      const float* p10 = &px[(size_t(iy) * W + ix1) * nc];
      const float* p01 = &px[(size_t(iy1) * W + ix) * nc];
      const float* p11 = &px[(size_t(iy1) * W + ix1) * nc];
      for (int c = 0; c < nc; ++c)
        o[c] = (1 - ay) * ((1 - ax) * p00[c] + ax * p10[c]) + ay * ((1 - ax) * p01[c] + ax * p11[c]);
    }

  std::error_code ec;
  fs::create_directories(cache_dir, ec);
  if (!fs::is_directory(cache_dir))
    throw Error(cache_dir, "cannot create the undistorted-image cache folder" + (ec ? ": " + ec.message() : std::string()) +
                               " (choose another with --undistort-cache)");
  io::write_atomic(out_path.string(), [&](const std::string& tmp) {
    auto o = OIIO::ImageOutput::create(tmp);
    if (!o) throw Error(tmp, "cannot create image writer: " + OIIO::geterror());
    OIIO::ImageSpec os(w.width, w.height, nc, out_type);
    os.channelnames = spec.channelnames;
    os.alpha_channel = spec.alpha_channel;
    if (spec.alpha_channel >= 0) os.attribute("oiio:UnassociatedAlpha", 1);
    if (!o->open(tmp, os) || !o->write_image(OIIO::TypeDesc::FLOAT, out.data()) || !o->close())
      throw Error(tmp, "cannot write image: " + o->geterror());
  });
  return out_path.string();
}

}  // namespace ptir
