// Python module `ptir`: the engine's data and renders as numpy arrays.
// Long calls release the GIL; engine errors arrive as ptir.Error (a RuntimeError).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/render/aov.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/mesh.h"
#include "ptir/transport/orient_normals.h"

namespace py = pybind11;
using namespace ptir;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

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

// A scene: the field and meshes it was built from are owned here, so the
// acceleration structure never outlives them.
struct PyScene {
  std::shared_ptr<GaussianField> field;
  std::vector<TriangleMesh> meshes;
  std::unique_ptr<SceneAccel> accel;
};

InteractionMode parse_mode(const std::string& mode) {
  if (mode == "aggregate") return InteractionMode::Aggregate;
  if (mode == "discrete") return InteractionMode::Discrete;
  throw Error("interaction mode must be 'aggregate' or 'discrete', got '" + mode + "'");
}

}  // namespace

PYBIND11_MODULE(ptir, m) {
  m.doc() = "PTIR: path-traced inverse rendering of 3D Gaussian splats";
  static py::exception<Error> error_type(m, "Error", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      error_type(e.what());
    } catch (const Cancelled& e) {
      PyErr_SetString(PyExc_KeyboardInterrupt, "cancelled");
    }
  });

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
      .def("ray", [](const Camera& c, float px, float py_) {
        Ray r = c.generate_ray(px, py_);
        return py::make_tuple(py::make_tuple(r.o.x, r.o.y, r.o.z), py::make_tuple(r.d.x, r.d.y, r.d.z));
      });
  m.def("load_cameras", &load_transforms_json, py::arg("path"), py::arg("width") = 0, py::arg("height") = 0,
        "Cameras of every frame of a NeRF-synthetic transforms_*.json.");

  py::class_<PyScene>(m, "Scene")
      .def(py::init([](std::shared_ptr<GaussianField> field, std::vector<TriangleMesh> meshes, int k) {
             auto s = std::make_unique<PyScene>();
             s->field = field ? field : std::make_shared<GaussianField>();
             s->meshes = std::move(meshes);
             AccelSettings settings;
             settings.k = k;
             py::gil_scoped_release release;
             s->accel = std::make_unique<SceneAccel>(*s->field, s->meshes, settings);
             return s;
           }),
           py::arg("gaussians"), py::arg("meshes") = std::vector<TriangleMesh>{}, py::arg("k") = 16)
      .def("orient_normals",
           [](PyScene& s, const std::vector<Camera>& cams) {
             py::gil_scoped_release release;
             OrientStats st = orient_normals_to_cameras(*s.field, *s.accel, cams);
             return std::make_pair(st.flipped, st.unseen);
           },
           py::arg("cameras"), "Face shortest-axis normals toward the cameras; returns (flipped, unseen).")
      .def("render_aov",
           [](PyScene& s, const Camera& cam, const std::string& aov, int spp, uint64_t seed, const std::string& mode,
              float tau_g) {
             AovSettings settings;
             settings.spp = spp;
             settings.seed = seed;
             settings.interaction.mode = parse_mode(mode);
             settings.interaction.tau_g = tau_g;
             Aov which = parse_aov(aov);
             Image img;
             {
               py::gil_scoped_release release;
               img = render_aov(*s.accel, cam, which, settings);
             }
             return image_array(img);
           },
           py::arg("camera"), py::arg("aov") = "preview", py::arg("spp") = 1, py::arg("seed") = 0,
           py::arg("mode") = "aggregate", py::arg("tau_g") = 0.5f,
           "Render an AOV; returns float32 (height, width, channels), last channel = coverage.")
      .def("trace_hits",
           [](PyScene& s, std::array<float, 3> o, std::array<float, 3> d, float tmin, float tmax) {
             Ray ray;
             ray.o = Vec3(o[0], o[1], o[2]);
             ray.d = normalize(Vec3(d[0], d[1], d[2]));
             ray.tmin = tmin;
             ray.tmax = tmax;
             std::vector<std::tuple<float, float, uint32_t>> hits;
             WalkEnd end = s.accel->walk(ray, [&](const GaussianHit& h) {
               hits.emplace_back(h.t, h.alpha, h.id);
               return true;
             });
             py::object mesh_t = end.mesh.valid ? py::object(py::float_(end.mesh.t)) : py::object(py::none());
             return py::make_tuple(hits, mesh_t);
           },
           py::arg("origin"), py::arg("direction"), py::arg("tmin") = 0.0f,
           py::arg("tmax") = std::numeric_limits<float>::infinity(),
           "All Gaussian hits (t_peak, alpha, id) in order, and the distance of the mesh that ended the walk (or None).");
}
