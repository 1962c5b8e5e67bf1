#include "ptir/scene/lens_model.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "ptir/core/error.h"

namespace ptir {

bool LensModel::distorted() const {
  if (kind == Kind::Pinhole) return false;
  for (double v : k)
    if (v != 0.0) return true;
  for (double v : kd)
    if (v != 0.0) return true;
  return p1 != 0.0 || p2 != 0.0;
}

Point2d LensModel::distort(const Point2d& x) const {
  const double u = x[0], v = x[1];
  if (kind == Kind::Pinhole) return x;
  if (kind == Kind::Fisheye) {
    const double r = std::sqrt(u * u + v * v);
    if (r < 1e-12) return x;
    const double th = std::atan(r), t2 = th * th;
    const double th_d = th * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
    const double s = th_d / r;
    return {u * s, v * s};
  }
  const double r2 = u * u + v * v;
  const double num = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3])));
  const double den = 1.0 + r2 * (kd[0] + r2 * (kd[1] + r2 * kd[2]));
  const double radial = num / den;
  return {u * radial + 2.0 * p1 * u * v + p2 * (r2 + 2.0 * u * u), v * radial + p1 * (r2 + 2.0 * v * v) + 2.0 * p2 * u * v};
}

Point2d LensModel::undistort(const Point2d& x_d) const {
  if (!distorted()) return x_d;
  Point2d x = x_d;
  for (int it = 0; it < 100; ++it) {
    const Point2d f = distort(x);
    const double ex = f[0] - x_d[0], ey = f[1] - x_d[1];
    if (ex * ex + ey * ey < 1e-26) return x;
    // Jacobian by central differences, step relative to the point's size.
    const double h = 1e-7 * std::max(1.0, std::sqrt(x[0] * x[0] + x[1] * x[1]));
    const Point2d a = distort({x[0] + h, x[1]}), b = distort({x[0] - h, x[1]});
    const Point2d c = distort({x[0], x[1] + h}), d = distort({x[0], x[1] - h});
    const double j00 = (a[0] - b[0]) / (2 * h), j10 = (a[1] - b[1]) / (2 * h);
    const double j01 = (c[0] - d[0]) / (2 * h), j11 = (c[1] - d[1]) / (2 * h);
    const double det = j00 * j11 - j01 * j10;
    if (!(std::fabs(det) > 1e-300)) break;
    x[0] -= (j11 * ex - j01 * ey) / det;
    x[1] -= (-j10 * ex + j00 * ey) / det;
    if (!std::isfinite(x[0]) || !std::isfinite(x[1])) break;
  }
  const Point2d f = distort(x);
  const double e = std::hypot(f[0] - x_d[0], f[1] - x_d[1]);
  if (std::isfinite(e) && e < 1e-9) return x;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return {nan, nan};
}

LensModel LensModel::scaled_to(int w, int h) const {
  LensModel l = *this;
  const double sx = double(w) / double(width), sy = double(h) / double(height);
  l.width = w;
  l.height = h;
  l.fx *= sx;
  l.cx *= sx;
  l.fy *= sy;
  l.cy *= sy;
  return l;
}

std::string LensModel::describe() const {
  char b[512];
  std::snprintf(b, sizeof b, "%s %dx%d fx %.17g fy %.17g cx %.17g cy %.17g k %.17g %.17g %.17g %.17g kd %.17g %.17g %.17g p %.17g %.17g",
                model.c_str(), width, height, fx, fy, cx, cy, k[0], k[1], k[2], k[3], kd[0], kd[1], kd[2], p1, p2);
  return b;
}

namespace {

struct ModelInfo {
  int id;
  const char* name;
  int params;
};
// COLMAP's camera model ids (src/colmap/sensor/models.h), including those we refuse.
constexpr ModelInfo kModels[] = {{0, "SIMPLE_PINHOLE", 3}, {1, "PINHOLE", 4},         {2, "SIMPLE_RADIAL", 4},
                                 {3, "RADIAL", 5},         {4, "OPENCV", 8},          {5, "OPENCV_FISHEYE", 8},
                                 {6, "FULL_OPENCV", 12},   {7, "FOV", 5},             {8, "SIMPLE_RADIAL_FISHEYE", 4},
                                 {9, "RADIAL_FISHEYE", 5}, {10, "THIN_PRISM_FISHEYE", 12}};

}  // namespace

std::string colmap_model_name(int model_id) {
  for (const ModelInfo& m : kModels)
    if (m.id == model_id) return m.name;
  return "";
}

int colmap_model_param_count(const std::string& model) {
  for (const ModelInfo& m : kModels)
    if (model == m.name) return m.params;
  return -1;
}

LensModel lens_from_colmap(const std::string& model, const std::vector<double>& p, int width, int height,
                           const std::string& where) {
  const int n = colmap_model_param_count(model);
  if (n < 0) throw Error(where, "unknown camera model '" + model + "'");
  if (int(p.size()) != n)
    throw Error(where, "camera model " + model + " has " + std::to_string(n) + " parameters, got " + std::to_string(p.size()));
  if (width <= 0 || height <= 0)
    throw Error(where, "camera size must be positive (got " + std::to_string(width) + "x" + std::to_string(height) + ")");
  for (double v : p)
    if (!std::isfinite(v)) throw Error(where, "camera " + model + " has a non-finite parameter");
  LensModel l;
  l.model = model;
  l.width = width;
  l.height = height;
  if (model == "SIMPLE_PINHOLE" || model == "SIMPLE_RADIAL" || model == "RADIAL") {
    l.fx = l.fy = p[0];
    l.cx = p[1];
    l.cy = p[2];
    if (model == "SIMPLE_RADIAL") l.k[0] = p[3];
    if (model == "RADIAL") l.k[0] = p[3], l.k[1] = p[4];
    l.kind = model == "SIMPLE_PINHOLE" ? LensModel::Kind::Pinhole : LensModel::Kind::RadialTangential;
  } else if (model == "PINHOLE" || model == "OPENCV" || model == "FULL_OPENCV" || model == "OPENCV_FISHEYE") {
    l.fx = p[0];
    l.fy = p[1];
    l.cx = p[2];
    l.cy = p[3];
    if (model == "PINHOLE") {
      l.kind = LensModel::Kind::Pinhole;
    } else if (model == "OPENCV_FISHEYE") {
      l.kind = LensModel::Kind::Fisheye;
      for (int i = 0; i < 4; ++i) l.k[size_t(i)] = p[size_t(4 + i)];
    } else {
      l.kind = LensModel::Kind::RadialTangential;
      l.k[0] = p[4];
      l.k[1] = p[5];
      l.p1 = p[6];
      l.p2 = p[7];
      if (model == "FULL_OPENCV") {
        l.k[2] = p[8];
        l.kd = {p[9], p[10], p[11]};
      }
    }
  } else {
    throw Error(where, "camera model " + model +
                           " is not supported (supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, "
                           "FULL_OPENCV, OPENCV_FISHEYE); undistort the images with `colmap image_undistorter` first");
  }
  if (!(l.fx > 0 && l.fy > 0)) throw Error(where, "camera " + model + " has a non-positive focal length");
  return l;
}

}  // namespace ptir
