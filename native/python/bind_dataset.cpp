// Python bindings of datasets: ptir.Dataset (posed training images with their
// optional ground-truth and prior maps; NeRF-synthetic/TensoIR sets or real
// captures), ptir.load_dataset and ptir.detect_layout.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ptir/scene/dataset.h"
#include "py_arrays.h"

namespace py = pybind11;
using namespace ptir;
using namespace ptir::py_bind;

void bind_dataset(py::module_& m) {
  py::class_<Dataset, std::shared_ptr<Dataset>>(m, "Dataset",
                                                "Posed training images (NeRF-synthetic/TensoIR set or a real capture); see load_dataset.")
      .def("__len__", &Dataset::size)
      .def_readonly("root", &Dataset::root)
      .def_readonly("split", &Dataset::split)
      .def_readonly("transforms_path", &Dataset::transforms_path)
      .def_readonly("width", &Dataset::width)
      .def_readonly("reduce", &Dataset::reduce)
      .def_readonly("source_width", &Dataset::source_width)
      .def_readonly("source_height", &Dataset::source_height)
      .def_readonly("height", &Dataset::height)
      .def_readonly("layout", &Dataset::layout)
      .def_readonly("gaussians_path", &Dataset::gaussians_path)
      .def_property_readonly("cameras", &Dataset::cameras)
      .def_property_readonly("exposures",
                             [](const Dataset& d) {
                               std::vector<double> e;
                               for (const DatasetView& v : d.views) e.push_back(v.exposure);
                               return e;
                             },
                             "Each view's EXIF exposure relative to the capture's median (1 without EXIF).")
      .def_property_readonly("view_names",
                             [](const Dataset& d) {
                               std::vector<std::string> n;
                               for (const DatasetView& v : d.views) n.push_back(v.camera.name);
                               return n;
                             })
      .def("files",
           [](const Dataset& d, size_t i) {
             const ViewFiles& f = d.views.at(i).files;
             py::dict r;
             r["image"] = f.image;
             r["mask"] = f.mask;
             r["gt_albedo"] = f.gt_albedo;
             r["gt_roughness"] = f.gt_roughness;
             r["gt_normal"] = f.gt_normal;
             r["prior_albedo"] = f.prior_albedo;
             r["prior_roughness"] = f.prior_roughness;
             return r;
           },
           py::arg("index"), "Paths of view i's files ('' where absent).")
      .def("target",
           [](const Dataset& d, size_t i) {
             std::shared_ptr<const TrainingImage> t;
             {
               py::gil_scoped_release release;
               t = d.target(i);
             }
             return py::make_tuple(image_or_none(t->rgb, false), image_or_none(t->alpha, true), t->has_alpha);
           },
           py::arg("index"), "(rgb (h, w, 3) linear straight colour, alpha (h, w), has_alpha) of view i.")
      .def("gt_albedo", [](const Dataset& d, size_t i) { return image_or_none(d.gt_albedo(i), false); }, py::arg("index"))
      .def("gt_roughness", [](const Dataset& d, size_t i) { return image_or_none(d.gt_roughness(i), true); }, py::arg("index"))
      .def("gt_normal", [](const Dataset& d, size_t i) { return image_or_none(d.gt_normal(i), false); }, py::arg("index"))
      .def("prior_albedo", [](const Dataset& d, size_t i) { return image_or_none(d.prior_albedo(i), false); }, py::arg("index"))
      .def("prior_roughness", [](const Dataset& d, size_t i) { return image_or_none(d.prior_roughness(i), true); },
           py::arg("index"));

  m.def("load_dataset",
        [](const std::string& path, const std::string& split, std::optional<std::string> prior, const std::string& layout,
           const std::string& images, int holdout, const std::string& test_list, const std::string& undistort_cache,
           const std::string& dataparser_transforms, const std::string& world, bool black_background, bool exif_exposure,
           const std::string& calibration, int max_image_side) {
          DatasetOptions o;
          o.split = split;
          if (prior) o.prior_dir = *prior;
          o.layout = layout;
          o.images = images;
          o.holdout = holdout;
          o.test_list = test_list;
          o.undistort_dir = undistort_cache;
          o.dataparser_transforms = dataparser_transforms;
          o.world = world;
          o.black_background = black_background;
          o.exif_exposure = exif_exposure;
          o.calibration = calibration;
          o.max_side = max_image_side;
          py::gil_scoped_release release;
          return std::shared_ptr<Dataset>(load_dataset(path, o));
        },
        py::arg("path"), py::arg("split") = "train", py::arg("prior") = py::none(), py::arg("layout") = "auto",
        py::arg("images") = "", py::arg("holdout") = 8, py::arg("test_list") = "", py::arg("undistort_cache") = "",
        py::arg("dataparser_transforms") = "", py::arg("world") = "auto", py::arg("black_background") = false,
        py::arg("exif_exposure") = true, py::arg("calibration") = "", py::arg("max_image_side") = 800,
        "Read a dataset folder: NeRF-synthetic/TensoIR (transforms_<split>.json; optional GT and prior maps), or a real "
        "capture (COLMAP, 3DGS output, nerfstudio; split train/test/all by holdout); docs/dataset_format.md.");
  m.def("detect_layout", &detect_layout, py::arg("path"), "The dataset layout of a folder ('' if none is recognised).");
}
