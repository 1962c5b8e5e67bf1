// Python module `ptir`: the engine's data and renders as numpy arrays.
// Long calls release the GIL; engine errors arrive as ptir.Error (a RuntimeError).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <tbb/global_control.h>

#include <chrono>
#include <limits>
#include <memory>
#include <optional>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/render/aov.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/mesh.h"
#include "ptir/scene/scene.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/orient_normals.h"
#include "ptir/transport/path_tracer.h"

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

// A scene: Gaussians, meshes, lights, environment, cameras and integrator
// settings, owned here with the path tracer (and its acceleration structure)
// built over them, so the tracer never outlives its data. Built from arrays
// (Scene(gaussians, meshes)), a scene file (load_scene) or JSON text/dicts.
struct PyScene {
  Scene scene;
  std::unique_ptr<PathTracer> tracer;
  PathStats last_stats;
  double last_seconds = 0.0;

  GaussianField& field() { return *scene.gaussians; }
  const SceneAccel& accel() const { return tracer->accel(); }
  void build(int k) {
    AccelSettings settings;
    settings.k = k;
    tracer = std::make_unique<PathTracer>(scene, settings);
  }
};

std::unique_ptr<PyScene> make_pyscene(Scene&& scene, int k = 32) {
  auto s = std::make_unique<PyScene>();
  s->scene = std::move(scene);
  s->build(k);
  return s;
}

const char* mode_name(InteractionMode m) { return m == InteractionMode::Discrete ? "discrete" : "aggregate"; }

py::dict integrator_dict(const IntegratorSettings& s) {
  py::dict d;
  d["spp"] = s.spp;
  d["bounces"] = s.max_bounces;
  d["seed"] = s.seed;
  d["interaction"] = mode_name(s.interaction.mode);
  d["tau_g"] = s.interaction.tau_g;
  d["geometric_criterion"] = s.geometric_criterion;
  d["self_intersection"] = s.self_intersection == SelfIntersection::FixedOffset ? "fixed" : "backface";
  d["self_range_scale"] = s.self_range_scale;
  d["fixed_offset"] = s.fixed_offset;
  d["fixed_range"] = s.fixed_range;
  d["min_throughput"] = s.min_throughput;
  d["pixel_filter"] = pixel_filter_name(s.filter.type);
  d["filter_width"] = s.filter.width;
  return d;
}

// Picks a camera: None (the first), a name, an index or a Camera.
Camera pick_camera(const PyScene& s, const py::object& cam) {
  if (cam.is_none()) return s.scene.camera("");
  if (py::isinstance<Camera>(cam)) return cam.cast<Camera>();
  if (py::isinstance<py::str>(cam)) return s.scene.camera(cam.cast<std::string>());
  if (py::isinstance<py::int_>(cam)) {
    long long i = cam.cast<long long>();
    long long n = (long long)s.scene.cameras.size();
    if (i < 0) i += n;
    if (i < 0 || i >= n)
      throw Error("camera index " + std::to_string(cam.cast<long long>()) + " out of range (" + std::to_string(n) +
                  " cameras)");
    return s.scene.cameras[size_t(i)];
  }
  throw Error("camera must be None, a name, an index or a ptir.Camera");
}

InteractionMode parse_mode(const std::string& mode) {
  if (mode == "aggregate") return InteractionMode::Aggregate;
  if (mode == "discrete") return InteractionMode::Discrete;
  throw Error("interaction mode must be 'aggregate' or 'discrete', got '" + mode + "'");
}

}  // namespace

void bind_losses(pybind11::module_& m);
void bind_optimize(pybind11::module_& m);
void bind_eval(pybind11::module_& m);

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

  py::class_<PyScene>(m, "Scene")
      .def(py::init([](std::shared_ptr<GaussianField> field, std::vector<TriangleMesh> meshes, int k) {
             auto s = std::make_unique<PyScene>();
             s->scene.gaussians = field ? field : std::make_shared<GaussianField>();
             s->scene.meshes = std::move(meshes);
             py::gil_scoped_release release;
             s->build(k);
             return s;
           }),
           py::arg("gaussians"), py::arg("meshes") = std::vector<TriangleMesh>{}, py::arg("k") = 32)
      .def("orient_normals",
           [](PyScene& s, const std::vector<Camera>& cams) {
             py::gil_scoped_release release;
             OrientStats st = orient_normals_to_cameras(s.field(), s.accel(), cams);
             return std::make_pair(st.flipped, st.unseen);
           },
           py::arg("cameras"), "Face shortest-axis normals toward the cameras; returns (flipped, unseen).")
      .def("render_aov",
           [](PyScene& s, const Camera& cam, const std::string& aov, int spp, uint64_t seed, const std::string& mode,
              float tau_g, std::optional<std::string> pixel_filter, std::optional<float> filter_width) {
             AovSettings settings;
             settings.spp = spp;
             settings.seed = seed;
             settings.filter = s.scene.integrator.filter;
             if (pixel_filter) settings.filter.type = parse_pixel_filter(*pixel_filter);
             if (filter_width) settings.filter.width = *filter_width;
             settings.interaction.mode = parse_mode(mode);
             settings.interaction.tau_g = tau_g;
             Aov which = parse_aov(aov);
             Image img;
             {
               py::gil_scoped_release release;
               img = render_aov(s.accel(), cam, which, settings);
             }
             return image_array(img);
           },
           py::arg("camera"), py::arg("aov") = "preview", py::arg("spp") = 1, py::arg("seed") = 0,
           py::arg("mode") = "aggregate", py::arg("tau_g") = 0.5f, py::arg("pixel_filter") = py::none(),
           py::arg("filter_width") = py::none(),
           "Render an AOV; returns float32 (height, width, channels), last channel = coverage. spp > 1 draws the "
           "sample offsets from the pixel filter (default: the scene's).")
      .def("trace_hits",
           [](PyScene& s, std::array<float, 3> o, std::array<float, 3> d, float tmin, float tmax) {
             Ray ray;
             ray.o = Vec3(o[0], o[1], o[2]);
             ray.d = normalize(Vec3(d[0], d[1], d[2]));
             ray.tmin = tmin;
             ray.tmax = tmax;
             std::vector<std::tuple<float, float, uint32_t>> hits;
             WalkEnd end = s.accel().walk(ray, [&](const GaussianHit& h) {
               hits.emplace_back(h.t, h.alpha, h.id);
               return true;
             });
             py::object mesh_t = end.mesh.valid ? py::object(py::float_(end.mesh.t)) : py::object(py::none());
             return py::make_tuple(hits, mesh_t);
           },
           py::arg("origin"), py::arg("direction"), py::arg("tmin") = 0.0f,
           py::arg("tmax") = std::numeric_limits<float>::infinity(),
           "All Gaussian hits (t_peak, alpha, id) in order, and the distance of the mesh that ended the walk (or None).")
      .def("render",
           [](PyScene& s, py::object camera, std::optional<int> spp, std::optional<int> bounces,
              std::optional<uint64_t> seed, std::optional<std::string> interaction,
              std::optional<bool> geometric_criterion, std::optional<std::string> self_intersection,
              std::optional<int> threads, std::optional<std::string> pixel_filter, std::optional<float> filter_width) {
             Camera cam = pick_camera(s, camera);
             IntegratorSettings settings = s.scene.integrator;
             if (spp) settings.spp = *spp;
             if (bounces) settings.max_bounces = *bounces;
             if (seed) settings.seed = *seed;
             if (interaction) settings.interaction.mode = parse_mode(*interaction);
             if (geometric_criterion) settings.geometric_criterion = *geometric_criterion;
             if (self_intersection) {
               if (*self_intersection == "backface") settings.self_intersection = SelfIntersection::BackfaceAware;
               else if (*self_intersection == "fixed") settings.self_intersection = SelfIntersection::FixedOffset;
               else throw Error("self_intersection must be 'backface' or 'fixed', got '" + *self_intersection + "'");
             }
             if (threads && *threads < 1) throw Error("threads must be at least 1");
             if (pixel_filter) settings.filter.type = parse_pixel_filter(*pixel_filter);
             if (filter_width) settings.filter.width = *filter_width;
             Image img;
             {
               py::gil_scoped_release release;
               std::optional<tbb::global_control> limit;
               if (threads) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(*threads));
               PathStats stats;
               auto t0 = std::chrono::steady_clock::now();
               img = render_path(*s.tracer, cam, settings, {}, &stats);
               s.last_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
               s.last_stats = stats;
             }
             return image_array(img);
           },
           py::arg("camera") = py::none(), py::arg("spp") = py::none(), py::arg("bounces") = py::none(),
           py::arg("seed") = py::none(), py::arg("interaction") = py::none(),
           py::arg("geometric_criterion") = py::none(), py::arg("self_intersection") = py::none(),
           py::arg("threads") = py::none(), py::arg("pixel_filter") = py::none(), py::arg("filter_width") = py::none(),
           "Path-trace an image: float32 (height, width, 4), linear RGB + coverage. camera: None (the first), a "
           "name, an index or a ptir.Camera; other arguments override the scene's integrator settings.")
      .def_property_readonly("cameras", [](const PyScene& s) { return s.scene.cameras; })
      .def_property_readonly("camera_names", [](const PyScene& s) {
        std::vector<std::string> names;
        for (const Camera& c : s.scene.cameras) names.push_back(c.name);
        return names;
      })
      .def_property_readonly("gaussians", [](const PyScene& s) { return s.scene.gaussians; })
      .def_property_readonly("meshes", [](const PyScene& s) { return s.scene.meshes; })
      .def_property_readonly("light_count", [](const PyScene& s) { return s.scene.emitters.size(); })
      .def_property_readonly("environment", [](const PyScene& s) -> py::object {
        if (s.scene.environment.latlong) return py::str("latlong");
        if (s.scene.environment.sg) return py::str("sg");
        return py::none();
      })
      .def_property_readonly("source_path", [](const PyScene& s) { return s.scene.source_path; })
      .def_property_readonly("integrator", [](const PyScene& s) { return integrator_dict(s.scene.integrator); },
                             "The scene's integrator settings (a copy, as a dict).")
      .def_property_readonly("last_render_stats", [](const PyScene& s) {
        py::dict d;
        d["paths"] = s.last_stats.paths;
        d["vertices"] = s.last_stats.vertices;
        d["shadow_rays"] = s.last_stats.shadow_rays;
        d["seconds"] = s.last_seconds;
        return d;
      });

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
  m.def("load_scene",
        [](const std::string& path, int k) {
          Scene scene = load_scene_json(path);
          orient_scene_normals(scene);
          return make_pyscene(std::move(scene), k);
        },
        py::arg("path"), py::arg("k") = 32, py::call_guard<py::gil_scoped_release>(),
        "Read a scene file (docs/scene_format.md) and build its path tracer.");
  m.def("scene_from_json_string",
        [](const std::string& text, const std::string& base_dir, const std::string& name, int k) {
          Scene scene = scene_from_json_string(text, base_dir, name);
          orient_scene_normals(scene);
          return make_pyscene(std::move(scene), k);
        },
        py::arg("text"), py::arg("base_dir") = "", py::arg("name") = "scene", py::arg("k") = 32,
        py::call_guard<py::gil_scoped_release>(),
        "A scene from JSON text (the scene-file schema); relative paths resolve against base_dir.");
  m.def("scene_from_dict",
        [](py::object obj, const std::string& base_dir, const std::string& name, int k) {
          std::string text = py::module_::import("json").attr("dumps")(obj).cast<std::string>();
          py::gil_scoped_release release;
          Scene scene = scene_from_json_string(text, base_dir, name);
          orient_scene_normals(scene);
          return make_pyscene(std::move(scene), k);
        },
        py::arg("scene"), py::arg("base_dir") = "", py::arg("name") = "scene", py::arg("k") = 32,
        "A scene from a dict with the scene-file schema (numpy arrays: call .tolist() first).");
  bind_losses(m);
  bind_optimize(m);
  bind_eval(m);
}
