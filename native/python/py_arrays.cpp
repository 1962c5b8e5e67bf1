#include "py_arrays.h"

#include <algorithm>

#include "ptir/core/error.h"

namespace ptir::py_bind {

// Copies an array of Vec3 into an (n, 3) float array.
FloatArray vec3_array(const std::vector<Vec3>& v) {
  FloatArray a({py::ssize_t(v.size()), py::ssize_t(3)});
  auto m = a.mutable_unchecked<2>();
  for (size_t i = 0; i < v.size(); ++i) {
    m(i, 0) = v[i].x; m(i, 1) = v[i].y; m(i, 2) = v[i].z;
  }
  return a;
}

void set_vec3(std::vector<Vec3>& dst, FloatArray a, size_t n, const char* what) {
  if (a.ndim() != 2 || size_t(a.shape(0)) != n || a.shape(1) != 3)
    throw Error(std::string(what) + " must have shape (" + std::to_string(n) + ", 3)");
  auto m = a.unchecked<2>();
  for (size_t i = 0; i < n; ++i) dst[i] = Vec3(m(i, 0), m(i, 1), m(i, 2));
}

FloatArray scalar_array(const std::vector<float>& v) {
  FloatArray a(py::ssize_t(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

void set_scalar(std::vector<float>& dst, FloatArray a, size_t n, const char* what) {
  if (a.ndim() != 1 || size_t(a.shape(0)) != n) throw Error(std::string(what) + " must have shape (" + std::to_string(n) + ",)");
  std::copy(a.data(), a.data() + n, dst.begin());
}

FloatArray image_array(const Image& img) {
  FloatArray a({py::ssize_t(img.height), py::ssize_t(img.width), py::ssize_t(img.channels)});
  std::copy(img.pixels.begin(), img.pixels.end(), a.mutable_data());
  return a;
}

py::object image_or_none(const Image& img, bool squeeze) {
  if (img.width == 0) return py::none();
  std::vector<py::ssize_t> shape = {img.height, img.width};
  if (!(squeeze && img.channels == 1)) shape.push_back(img.channels);
  FloatArray a(shape);
  std::copy(img.pixels.begin(), img.pixels.end(), a.mutable_data());
  return std::move(a);
}

}  // namespace ptir::py_bind
