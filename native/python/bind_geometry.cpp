// Python bindings of the scene's pieces: the Gaussian field (arrays, PLY
// read/write), triangle meshes and cameras.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>

#include "ptir/core/error.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/gaussians.h"
#include "ptir/scene/mesh.h"
#include "ptir/scene/splat_up_axis.h"
#include "py_arrays.h"

namespace py = pybind11;
using namespace ptir;
using namespace ptir::py_bind;

void bind_geometry(py::module_& m) {
  py::class_<GaussianField, std::shared_ptr<GaussianField>>(m, "GaussianField")
      .def("__len__", &GaussianField::size)
      .def_property_readonly("sh_degree", [](const GaussianField& f) { return f.sh_degree; })
      .def_property_readonly("normals_from_file", [](const GaussianField& f) { return f.normals_from_file; })
      .def_property_readonly("position", [](const GaussianField& f) { return vec3_array(f.position); })
      .def_property_readonly("scale", [](const GaussianField& f) { return vec3_array(f.scale); })
      .def_property_readonly("opacity", [](const GaussianField& f) { return scalar_array(f.opacity); })
      .def_property_readonly("rotation", [](const GaussianField& f) {
        FloatArray a({py::ssize_t(f.size()), py::ssize_t(4)});
        auto w = a.mutable_unchecked<2>();
        for (size_t i = 0; i < f.size(); ++i)
          for (int c = 0; c < 4; ++c) w(i, c) = f.rotation[i][c];
        return a;
      })
      .def_property("normal", [](const GaussianField& f) { return vec3_array(f.normal); },
                    [](GaussianField& f, FloatArray a) { set_vec3(f.normal, a, f.size(), "normal"); })
      .def_property("albedo", [](const GaussianField& f) { return vec3_array(f.albedo); },
                    [](GaussianField& f, FloatArray a) { set_vec3(f.albedo, a, f.size(), "albedo"); })
      .def_property("roughness", [](const GaussianField& f) { return scalar_array(f.roughness); },
                    [](GaussianField& f, FloatArray a) { set_scalar(f.roughness, a, f.size(), "roughness"); })
      .def_property("metallic", [](const GaussianField& f) { return scalar_array(f.metallic); },
                    [](GaussianField& f, FloatArray a) { set_scalar(f.metallic, a, f.size(), "metallic"); });

  m.def("load_gaussians", [](const std::string& path) { return std::make_shared<GaussianField>(load_gaussians(path)); },
        py::arg("path"), py::call_guard<py::gil_scoped_release>(), "Read a 3DGS .ply (activated values).");
  m.def("save_gaussians", [](const std::string& path, const GaussianField& f) { save_gaussians(path, f); }, py::arg("path"),
        py::arg("field"), py::call_guard<py::gil_scoped_release>(),
        "Write the field: input properties unchanged plus material properties.");
  m.def("splat_up_axis",
        [](const GaussianField& f, const std::string& up, const std::vector<Camera>& cameras) {
          const std::string text = up_axis_json(decide_up_axis(f, up, cameras));
          return py::module_::import("json").attr("loads")(text);
        },
        py::arg("field"), py::arg("up") = "", py::arg("cameras") = std::vector<Camera>(),
        "The splats' up axis as `ptir optimize` without --dataset decides it (scene/splat_up_axis.h): a dict "
        "with 'up', 'source' and the cues measured.");

  py::class_<TriangleMesh>(m, "TriangleMesh")
      .def_readonly("name", &TriangleMesh::name)
      .def_property_readonly("vertices", [](const TriangleMesh& t) { return vec3_array(t.vertices); })
      .def_property_readonly("triangle_count", [](const TriangleMesh& t) { return t.triangles.size(); });
  m.def("load_mesh", &load_mesh, py::arg("path"), "Read a triangle mesh (.ply or .obj).");

  py::class_<Camera>(m, "Camera")
      .def(py::init([](FloatArray c2w, float fov_x, int width, int height) {
             if (c2w.size() != 16) throw Error("camera_to_world must have 16 entries (4x4)");
             return make_camera(c2w.data(), fov_x, width, height);
           }),
           py::arg("camera_to_world"), py::arg("fov_x"), py::arg("width"), py::arg("height"))
      .def_readonly("name", &Camera::name)
      .def_readonly("image_path", &Camera::image_path)
      .def_readonly("width", &Camera::width)
      .def_readonly("height", &Camera::height)
      .def_readonly("fov_x", &Camera::fov_x)
      .def_readonly("fx", &Camera::fx)
      .def_readonly("fy", &Camera::fy)
      .def_readonly("cx", &Camera::cx)
      .def_readonly("cy", &Camera::cy)
      .def_property_readonly("camera_to_world",
                             [](const Camera& c) {
                               // 4x4 row-major, NeRF convention (camera looks down -z, +y up).
                               const Affine& a = c.cam_to_world;
                               py::list rows;
                               for (int r = 0; r < 3; ++r)
                                 rows.append(py::make_tuple(a.linear.m[r][0], a.linear.m[r][1], a.linear.m[r][2],
                                                            a.translation[r]));
                               rows.append(py::make_tuple(0.0f, 0.0f, 0.0f, 1.0f));
                               return rows;
                             })
      .def("ray", [](const Camera& c, float px, float py_) {
        Ray r = c.generate_ray(px, py_);
        return py::make_tuple(py::make_tuple(r.o.x, r.o.y, r.o.z), py::make_tuple(r.d.x, r.d.y, r.d.z));
      });
  m.def("load_cameras", &load_transforms_json, py::arg("path"), py::arg("width") = 0, py::arg("height") = 0,
        "Cameras of every frame of a NeRF-synthetic transforms_*.json.");

}
