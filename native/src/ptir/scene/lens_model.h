// Lens models of real captures: COLMAP's camera models and the distortion keys of
// nerfstudio / instant-ngp transforms.json, as one model, in double precision.
//
// Image points are continuous pixel coordinates with the origin at the top-left
// CORNER of the image (pixel centres at +0.5; COLMAP's convention, see camera.h).
// A camera-space point (X, Y, Z), Z > 0 in front (COLMAP: +z forward, y down),
// has normalized coordinates x = (X/Z, Y/Z); the lens maps x to distorted x_d,
// and the image point is (fx x_d.x + cx, fy x_d.y + cy).
//
//   RadialTangential (SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, nerfstudio OPENCV):
//     r2 = |x|^2
//     radial = (1 + k1 r2 + k2 r2^2 + k3 r2^3 + k4 r2^4) / (1 + k5 r2 + k6 r2^2 + k7 r2^3)
//     x_d = x radial + (2 p1 x y + p2 (r2 + 2 x^2),  p1 (r2 + 2 y^2) + 2 p2 x y)
//   (COLMAP's FULL_OPENCV k4, k5, k6 -- the denominator -- are our k5, k6, k7;
//    nerfstudio's k4 is our k4, the r^8 term.)
//   Fisheye (OPENCV_FISHEYE, nerfstudio OPENCV_FISHEYE): r = |x|, theta = atan(r),
//     theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8),
//     x_d = x theta_d / r  (x_d = x at r = 0).
//
// undistort() inverts the lens by Newton's method on the 2x2 system (Jacobian by
// central differences), from x_d as the first guess.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace ptir {

using Point2d = std::array<double, 2>;

struct LensModel {
  enum class Kind { Pinhole, RadialTangential, Fisheye };
  std::string model = "PINHOLE";  // the model name as the file gives it (for messages and the cache key)
  Kind kind = Kind::Pinhole;
  int width = 0, height = 0;      // the image size these intrinsics are for
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 4> k{};      // radial numerator k1..k4 (fisheye: theta polynomial k1..k4)
  std::array<double, 3> kd{};     // radial denominator k5..k7 (FULL_OPENCV's k4..k6)
  double p1 = 0, p2 = 0;          // tangential

  // True when some distortion coefficient is non-zero.
  bool distorted() const;
  Point2d distort(const Point2d& x) const;
  // The x with distort(x) = x_d (Newton; converges for every lens COLMAP
  // accepts inside the image). Returns {NaN, NaN} if it does not converge.
  Point2d undistort(const Point2d& x_d) const;
  Point2d image_from_camera(const Point2d& x) const { const Point2d d = distort(x); return {fx * d[0] + cx, fy * d[1] + cy}; }
  Point2d camera_from_image(const Point2d& p) const { return undistort({(p[0] - cx) / fx, (p[1] - cy) / fy}); }
  // The same lens for a w x h image of the same view (intrinsics scaled per axis).
  LensModel scaled_to(int w, int h) const;
  // Every parameter as text (cache keys, messages).
  std::string describe() const;
};

// A COLMAP camera: model name (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL,
// OPENCV, FULL_OPENCV, OPENCV_FISHEYE) and its parameters in COLMAP's order.
// Throws ptir::Error("<where>: ...") for another model or a wrong parameter count.
LensModel lens_from_colmap(const std::string& model, const std::vector<double>& params, int width, int height,
                           const std::string& where);

// COLMAP's numeric model id -> name ("" for an unknown id).
std::string colmap_model_name(int model_id);
int colmap_model_param_count(const std::string& model);  // -1 for an unknown name

}  // namespace ptir
