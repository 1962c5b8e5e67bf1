// Python bindings of image files: read_image / write_image.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/io/image.h"
#include "py_arrays.h"

namespace py = pybind11;
using namespace ptir;
using namespace ptir::py_bind;

void bind_image(py::module_& m) {
  m.def("read_image",
        [](const std::string& path, bool linear) {
          Image img;
          {
            py::gil_scoped_release release;
            img = read_image(path, linear ? Encoding::Colour : Encoding::Data);
          }
          return image_array(img);
        },
        py::arg("path"), py::arg("linear") = true,
        "Read an image as float32 (height, width, channels); 8-bit colour files are decoded from sRGB when "
        "linear is true, EXR/HDR are returned as stored.");
  m.def("write_image",
        [](const std::string& path, FloatArray a, bool colour) {
          if (a.ndim() != 2 && a.ndim() != 3) throw Error(path, "image must have shape (h, w) or (h, w, c)");
          int h = int(a.shape(0)), w = int(a.shape(1)), c = a.ndim() == 3 ? int(a.shape(2)) : 1;
          static const char* names4[] = {"R", "G", "B", "A"};
          std::vector<std::string> names;
          if (c == 1) names = {"Y"};
          else if (c <= 4) for (int i = 0; i < c; ++i) names.push_back(names4[i]);
          else for (int i = 0; i < c; ++i) names.push_back("C" + std::to_string(i));
          Image img(w, h, names);
          std::copy(a.data(), a.data() + img.pixels.size(), img.pixels.begin());
          py::gil_scoped_release release;
          write_image(path, img, colour ? Encoding::Colour : Encoding::Data);
        },
        py::arg("path"), py::arg("image"), py::arg("colour") = true,
        "Write float (h, w[, c]) linear values: EXR/HDR as is, 8-bit formats sRGB-encoded when colour is true.");
}
