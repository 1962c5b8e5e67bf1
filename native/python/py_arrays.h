// Shared by the bind_*.cpp files of the Python module: numpy <-> engine arrays.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "ptir/io/image.h"
#include "ptir/math/vec.h"

namespace ptir::py_bind {

namespace py = pybind11;
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

// (n, 3) float array of Vec3s, and back (shape checked against n; Error names `what`).
FloatArray vec3_array(const std::vector<Vec3>& v);
void set_vec3(std::vector<Vec3>& dst, FloatArray a, size_t n, const char* what);
// (n,) float array, and back.
FloatArray scalar_array(const std::vector<float>& v);
void set_scalar(std::vector<float>& dst, FloatArray a, size_t n, const char* what);
// (height, width, channels) float array.
FloatArray image_array(const Image& img);
// (height, width[, channels]) (channels dropped when 1 and squeeze), or None for an empty image.
py::object image_or_none(const Image& img, bool squeeze);

}  // namespace ptir::py_bind
