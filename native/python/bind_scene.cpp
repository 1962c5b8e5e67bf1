// Python bindings of ptir.Scene: a scene with its path tracer, built from arrays
// or a scene file / JSON, rendered (path traced or AOVs) from Python.
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
#include "ptir/scene/mesh.h"
#include "ptir/scene/scene.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/orient_normals.h"
#include "ptir/transport/path_tracer.h"
#include "py_arrays.h"

namespace py = pybind11;
using namespace ptir;
using namespace ptir::py_bind;

namespace {

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

py::dict integrator_dict(const IntegratorSettings& s) {
  py::dict d;
  d["spp"] = s.spp;
  d["bounces"] = s.max_bounces;
  d["seed"] = s.seed;
  d["interaction"] = interaction_mode_name(s.interaction.mode);
  d["tau_g"] = s.interaction.tau_g;
  d["geometric_criterion"] = s.geometric_criterion;
  d["self_intersection"] = self_intersection_name(s.self_intersection);
  d["pixel_filter"] = pixel_filter_name(s.filter.type);
  d["filter_width"] = s.filter.width;
  d["self_range_scale"] = s.self_range_scale;
  d["fixed_offset"] = s.fixed_offset;
  d["fixed_range"] = s.fixed_range;
  d["min_throughput"] = s.min_throughput;
  d["light_selection"] = light_selection_name(s.light_selection);
  d["russian_roulette"] = s.russian_roulette;
  d["min_light_bounces"] = s.min_light_bounces;
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


using SceneClass = py::class_<PyScene>;

// Construction from arrays and normal orientation.
void def_scene_construction(SceneClass& cls) {
  cls
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
           py::arg("cameras"), "Face shortest-axis normals toward the cameras; returns (flipped, unseen).");
}

// render_aov, trace_hits, render.
void def_scene_renders(SceneClass& cls) {
  cls
      .def("render_aov",
           [](PyScene& s, const Camera& cam, const std::string& aov, int spp, uint64_t seed, const std::string& mode,
              float tau_g, std::optional<std::string> pixel_filter, std::optional<float> filter_width) {
             AovSettings settings;
             settings.spp = spp;
             settings.seed = seed;
             settings.filter = s.scene.integrator.filter;
             if (pixel_filter) settings.filter.type = parse_pixel_filter(*pixel_filter);
             if (filter_width) settings.filter.width = *filter_width;
             settings.interaction.mode = parse_interaction_mode(mode, "interaction mode");
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
              std::optional<int> threads, std::optional<std::string> pixel_filter, std::optional<float> filter_width,
              bool transparent) {
             Camera cam = pick_camera(s, camera);
             IntegratorSettings settings = s.scene.integrator;
             if (spp) settings.spp = *spp;
             if (bounces) settings.max_bounces = *bounces;
             if (seed) settings.seed = *seed;
             if (interaction) settings.interaction.mode = parse_interaction_mode(*interaction, "interaction mode");
             if (geometric_criterion) settings.geometric_criterion = *geometric_criterion;
             if (self_intersection) settings.self_intersection = parse_self_intersection(*self_intersection);
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
               img = render_path(*s.tracer, cam, settings, {}, &stats, nullptr, transparent);
               s.last_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
               s.last_stats = stats;
             }
             return image_array(img);
           },
           py::arg("camera") = py::none(), py::arg("spp") = py::none(), py::arg("bounces") = py::none(),
           py::arg("seed") = py::none(), py::arg("interaction") = py::none(),
           py::arg("geometric_criterion") = py::none(), py::arg("self_intersection") = py::none(),
           py::arg("threads") = py::none(), py::arg("pixel_filter") = py::none(), py::arg("filter_width") = py::none(),
           py::arg("transparent") = false,
           "Path-trace an image: float32 (height, width, 4), linear RGB + coverage A, the estimator's image (with "
           "transparent=True, Film > Transparent: RGB premultiplied by A; `ptir render` files make an opaque "
           "film's A 1 in front of an environment: docs/alpha.md). camera: None (the first), a name, an index "
           "or a ptir.Camera; other arguments override the scene's integrator settings.");
}

// Read-only views of the scene's contents and the last render's statistics.
void def_scene_properties(SceneClass& cls) {
  cls
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
        if (!s.scene.environment.present()) return py::none();
        return py::str(s.scene.environment->type());
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

}

}  // namespace

void bind_scene(py::module_& m) {
  SceneClass cls(m, "Scene");
  def_scene_construction(cls);
  def_scene_renders(cls);
  def_scene_properties(cls);
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
}
