// Distorted captures are resampled once to a pinhole image (the renderer's camera
// is a pinhole), and the results are cached on disk.
//
// Which pinhole: the lens's own focal lengths fx, fy (SIMPLE_* models: fx = fy = f)
// and principal point, so the centre of the image keeps its resolution.
// Which crop: the largest axis-aligned window of whole pixels that the
// undistorted image border encloses -- every output pixel's centre maps inside
// the source image (between the outermost pixel centres), so no pixel is blank
// and none is extrapolated. The border is sampled at every border pixel centre
// and undistorted (lens_model.h); the window is then
//   x0 = ceil(max over the left border of u - 0.5), width = floor(min over the right border of u + 0.5) - x0
// (same for y), limited to one image size on either side of the principal point
// (wide fisheye lenses). The camera's principal point becomes (cx - x0, cy - y0).
//
// Resampling: bilinear, in the file's stored values (sRGB-encoded for 8/16-bit
// files, as COLMAP's undistorter does), every channel (alpha included); the
// output keeps the source's bit depth (PNG for integer sources, EXR for float).
// Masks are resampled the same way.
//
// Cache: <cache_dir>/<stem>.<key>.png|exr, where key is a 64-bit hash of the
// source path, its size and modification time, the lens parameters and the
// window, so a changed image or model is never served stale. Written atomically.
#pragma once

#include <string>

#include "ptir/scene/lens_model.h"

namespace ptir {

struct PinholeWindow {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // of the output image (principal point already shifted)
  int x0 = 0, y0 = 0;                      // window origin in the uncropped pinhole image
  int width = 0, height = 0;
};

// The pinhole and window for `lens` (at lens.width x lens.height). For an
// undistorted lens: the same intrinsics and the whole image. Throws
// ptir::Error("<where>: ...") when the lens cannot be inverted at the image
// border or leaves an empty window.
PinholeWindow plan_undistortion(const LensModel& lens, const std::string& where);

// The undistorted version of image `src` (whose size must be the lens's) under
// `cache_dir`, made now unless already cached. Returns its path.
std::string undistorted_image(const std::string& src, const LensModel& lens, const PinholeWindow& window,
                              const std::string& cache_dir);

}  // namespace ptir
