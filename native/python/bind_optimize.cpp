// Python bindings of the inversion: datasets and the optimiser (the same loop as
// `ptir optimize`), with a per-iteration callback and cancellation.
//
//   ds = ptir.load_dataset("DIR", split="train", prior=None, layout="auto", images="", holdout=8, ...)
//   opt = ptir.Optimizer(ds or "DIR", "in.ply" or field, scene=None, iters=800, spp=32, ...)
//   opt.run(out="OUT", callback=lambda info: True, checkpoint_every=50)   # "finished" | "cancelled"
//   opt.step(); opt.cancel(); opt.load_checkpoint(p); opt.write_outputs(d)
//   ptir.optimize(dataset, gaussians, out, ..., resume=False, callback=None)
//
// The GIL is released while rendering; the callback runs with it held and may
// return False to stop; opt.cancel() (e.g. from another thread) stops after the
// current render; Ctrl-C (KeyboardInterrupt) stops after the current iteration
// (Python sees the signal only between iterations). Stopping writes the
// checkpoint and outputs (when out is given) before returning "cancelled" or
// re-raising the callback's exception / KeyboardInterrupt.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <tbb/global_control.h>

#include <atomic>
#include <filesystem>
#include <memory>
#include <optional>

#include "ptir/core/error.h"
#include "ptir/scene/dataset.h"
#include "ptir/optim/optimizer.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene.h"
#include "ptir/scene/scene_json.h"

namespace py = pybind11;
using namespace ptir;

namespace {

using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

py::object image_or_none(const Image& img, bool squeeze) {
  if (img.width == 0) return py::none();
  std::vector<py::ssize_t> shape = {img.height, img.width};
  if (!(squeeze && img.channels == 1)) shape.push_back(img.channels);
  FloatArray a(shape);
  std::copy(img.pixels.begin(), img.pixels.end(), a.mutable_data());
  return std::move(a);
}

py::dict log_dict(const IterationLog& l) {
  py::dict d;
  d["iteration"] = l.iteration;
  d["loss"] = l.loss;
  d["image"] = l.image;
  d["tv"] = l.tv;
  d["prior"] = l.prior;
  d["prior_weight"] = l.prior_weight;
  d["seconds"] = l.seconds;
  d["primal_s"] = l.primal_s;
  d["backward_s"] = l.backward_s;
  d["regulariser_s"] = l.regulariser_s;
  d["update_s"] = l.update_s;
  d["cpu_s"] = l.cpu_s;
  d["primal_cpu_s"] = l.primal_cpu_s;
  d["backward_cpu_s"] = l.backward_cpu_s;
  d["views"] = l.views;
  return d;
}

struct PyOptimizer {
  std::unique_ptr<Optimizer> opt;
  std::atomic<bool> cancel_flag{false};
  std::optional<int> threads;

  std::optional<tbb::global_control> limit() const {
    std::optional<tbb::global_control> l;
    if (threads) l.emplace(tbb::global_control::max_allowed_parallelism, size_t(*threads));
    return l;
  }
};

std::shared_ptr<const Dataset> dataset_from(const py::object& obj, const std::string& split, const std::optional<std::string>& prior) {
  if (py::isinstance<Dataset>(obj)) return obj.cast<std::shared_ptr<Dataset>>();
  if (py::isinstance<py::str>(obj) || py::hasattr(obj, "__fspath__")) {
    DatasetOptions o;
    o.split = split;
    if (prior) o.prior_dir = *prior;
    std::string path = py::str(obj).cast<std::string>();
    py::gil_scoped_release release;
    return std::shared_ptr<const Dataset>(load_dataset(path, o));
  }
  throw Error("dataset must be a folder path or a ptir.Dataset");
}

std::unique_ptr<PyOptimizer> make_optimizer(py::object dataset, py::object gaussians, std::optional<std::string> scene_path,
                                            int iters, int spp, int bounces, const std::string& env,
                                            std::pair<int, int> env_size, uint64_t seed, int views_per_iter, int crop,
                                            const std::string& loss_space, float lambda_tv, bool optimize_metallic,
                                            bool optimize_meshes, const std::string& split, std::optional<std::string> prior,
                                            std::optional<int> threads, int k, std::optional<std::string> env_init,
                                            bool fix_env) {
  OptimizerSettings s;
  s.iterations = iters;
  s.integrator.spp = spp;
  s.integrator.max_bounces = bounces;
  s.seed = seed;
  s.views_per_iteration = views_per_iter;
  s.crop_size = crop;
  s.lambda_tv = lambda_tv;
  s.accel.k = k;
  if (loss_space == "srgb") s.srgb_loss = true;
  else if (loss_space == "linear") s.srgb_loss = false;
  else throw Error("loss_space must be 'srgb' or 'linear', got '" + loss_space + "'");
  if (env == "latlong") s.params.env = EnvMode::LatLong;
  else if (env == "sg") s.params.env = EnvMode::SG;
  else throw Error("env must be 'latlong' or 'sg', got '" + env + "'");
  s.params.env_width = env_size.first;
  s.params.env_height = env_size.second;
  s.params.optimize_metallic = optimize_metallic;
  s.params.optimize_meshes = optimize_meshes;
  if (env_init) s.params.env_init_path = *env_init;
  s.params.optimize_env = !fix_env;
  if (fix_env && !env_init) throw Error("fix_env needs env_init (the known environment map)");
  if (threads && *threads < 1) throw Error("threads must be at least 1");

  auto data = dataset_from(dataset, split, prior);
  s.integrator.filter = dataset_pixel_filter(*data);  // the views' own filter, else Blender's default
  std::shared_ptr<GaussianField> field;
  if (py::isinstance<GaussianField>(gaussians)) field = std::make_shared<GaussianField>(gaussians.cast<const GaussianField&>());
  else if (py::isinstance<py::str>(gaussians) || py::hasattr(gaussians, "__fspath__")) {
    std::string path = py::str(gaussians).cast<std::string>();
    py::gil_scoped_release release;
    field = std::make_shared<GaussianField>(load_gaussians(path));
  } else {
    throw Error("gaussians must be a .ply path or a ptir.GaussianField");
  }
  auto p = std::make_unique<PyOptimizer>();
  p->threads = threads;
  py::gil_scoped_release release;
  auto limit = p->limit();
  Scene scene;
  if (scene_path) {
    scene = load_scene_json(*scene_path);
    if (scene.gaussians && scene.gaussians->size() > 0)
      throw Error(*scene_path, "the scene file has Gaussians; pass them as `gaussians` instead");
    s.integrator.interaction = scene.integrator.interaction;
    s.integrator.geometric_criterion = scene.integrator.geometric_criterion;
    s.integrator.self_intersection = scene.integrator.self_intersection;
    s.integrator.self_range_scale = scene.integrator.self_range_scale;
    s.integrator.fixed_offset = scene.integrator.fixed_offset;
    s.integrator.fixed_range = scene.integrator.fixed_range;
  } else if (optimize_meshes) {
    throw Error("optimize_meshes needs a scene with meshes");
  }
  scene.gaussians = field;
  scene.source_path = scene_path ? *scene_path : "python";
  p->opt = std::make_unique<Optimizer>(std::move(scene), data, s);
  return p;
}

// Runs the loop; rethrows what the callback raised (after the outputs are written).
std::string run(PyOptimizer& p, std::optional<std::string> out, py::object callback, int checkpoint_every) {
  RunOptions ro;
  ro.out_dir = out ? *out : "";
  ro.checkpoint_every = checkpoint_every;
  ro.cancel = &p.cancel_flag;
  p.cancel_flag.store(false);
  std::optional<py::error_already_set> error;
  ro.on_iteration = [&](const IterationLog& l) {
    py::gil_scoped_acquire gil;
    try {
      if (!callback.is_none()) {
        py::object r = callback(log_dict(l));
        if (!r.is_none() && !r.cast<bool>()) return false;
      }
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    } catch (py::error_already_set& e) {
      error.emplace(std::move(e));
      return false;
    }
    return true;
  };
  RunResult r;
  {
    py::gil_scoped_release release;
    auto limit = p.limit();
    r = run_optimizer(*p.opt, ro);
  }
  if (error) throw std::move(*error);
  return r == RunResult::Finished ? "finished" : "cancelled";
}

}  // namespace

void bind_optimize(py::module_& m) {
  py::class_<Dataset, std::shared_ptr<Dataset>>(m, "Dataset",
                                                "Posed training images (NeRF-synthetic/TensoIR set or a real capture); see load_dataset.")
      .def("__len__", &Dataset::size)
      .def_readonly("root", &Dataset::root)
      .def_readonly("split", &Dataset::split)
      .def_readonly("transforms_path", &Dataset::transforms_path)
      .def_readonly("width", &Dataset::width)
      .def_readonly("height", &Dataset::height)
      .def_readonly("layout", &Dataset::layout)
      .def_readonly("gaussians_path", &Dataset::gaussians_path)
      .def_property_readonly("cameras", &Dataset::cameras)
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
           const std::string& dataparser_transforms, const std::string& world, bool black_background) {
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
          py::gil_scoped_release release;
          return std::shared_ptr<Dataset>(load_dataset(path, o));
        },
        py::arg("path"), py::arg("split") = "train", py::arg("prior") = py::none(), py::arg("layout") = "auto",
        py::arg("images") = "", py::arg("holdout") = 8, py::arg("test_list") = "", py::arg("undistort_cache") = "",
        py::arg("dataparser_transforms") = "", py::arg("world") = "auto", py::arg("black_background") = false,
        "Read a dataset folder: NeRF-synthetic/TensoIR (transforms_<split>.json; optional GT and prior maps), or a real "
        "capture (COLMAP, 3DGS output, nerfstudio; split train/test/all by holdout); docs/dataset_format.md.");
  m.def("detect_layout", &detect_layout, py::arg("path"), "The dataset layout of a folder ('' if none is recognised).");

  py::class_<PyOptimizer>(m, "Optimizer",
                          "The inverse-rendering optimiser (the loop of `ptir optimize`): Adam on per-Gaussian albedo, "
                          "roughness (and optionally metallic) and the environment, gradients by path replay.")
      .def(py::init(&make_optimizer), py::arg("dataset"), py::arg("gaussians"), py::arg("scene") = py::none(),
           py::arg("iters") = 800, py::arg("spp") = 32, py::arg("bounces") = 2, py::arg("env") = "latlong",
           py::arg("env_size") = std::pair<int, int>(128, 64), py::arg("seed") = 0, py::arg("views_per_iter") = 1,
           py::arg("crop") = 0, py::arg("loss_space") = "srgb", py::arg("lambda_tv") = 0.095f,
           py::arg("optimize_metallic") = false, py::arg("optimize_meshes") = false, py::arg("split") = "train",
           py::arg("prior") = py::none(), py::arg("threads") = py::none(), py::arg("k") = 16,
           py::arg("env_init") = py::none(), py::arg("fix_env") = false)
      .def_property_readonly("iteration", [](const PyOptimizer& p) { return p.opt->iteration(); })
      .def_property("iterations", [](const PyOptimizer& p) { return p.opt->settings().iterations; },
                    [](PyOptimizer& p, int n) {
                      if (n < 0) throw Error("iterations must be >= 0");
                      p.opt->set_iterations(n);
                    })
      .def("step",
           [](PyOptimizer& p) {
             p.cancel_flag.store(false);
             IterationLog l;
             {
               py::gil_scoped_release release;
               auto limit = p.limit();
               l = p.opt->step(&p.cancel_flag);
             }
             return log_dict(l);
           },
           "One iteration; returns its log entry.")
      .def("run", &run, py::arg("out") = py::none(), py::arg("callback") = py::none(), py::arg("checkpoint_every") = 50,
           "Iterate up to `iterations`. callback(info) after each iteration; return False to stop. Writes "
           "out/checkpoint.bin every checkpoint_every iterations and, at the end or when stopped, the checkpoint and "
           "the outputs. Returns 'finished' or 'cancelled'.")
      .def("cancel", [](PyOptimizer& p) { p.cancel_flag.store(true); },
           "Stop a running step/run (thread-safe): the current iteration is abandoned, the state stays at the last "
           "completed one.")
      .def("save_checkpoint", [](const PyOptimizer& p, const std::string& path) { p.opt->save_checkpoint(path); },
           py::arg("path"), py::call_guard<py::gil_scoped_release>())
      .def("load_checkpoint", [](PyOptimizer& p, const std::string& path) { p.opt->load_checkpoint(path); }, py::arg("path"),
           py::call_guard<py::gil_scoped_release>(), "Continue from a checkpoint (same inputs and settings required).")
      .def("write_outputs", [](const PyOptimizer& p, const std::string& dir) { p.opt->write_outputs(dir); }, py::arg("dir"),
           py::call_guard<py::gil_scoped_release>(), "gaussians.ply, env.exr, log.csv into dir.")
      .def_property_readonly("gaussians", [](const PyOptimizer& p) { return p.opt->scene().gaussians; },
                             "The field being optimised (live: albedo/roughness/metallic/normal arrays).")
      .def_property_readonly("environment", [](const PyOptimizer& p) { return image_or_none(p.opt->environment_image(), false); },
                             "The recovered environment, lat-long (h, w, 3) linear, Blender orientation.")
      .def_property_readonly("dataset", [](const PyOptimizer& p) { return std::const_pointer_cast<Dataset>(p.opt->dataset_ptr()); })
      .def_property_readonly("log",
                             [](const PyOptimizer& p) {
                               py::list l;
                               for (const IterationLog& e : p.opt->log()) l.append(log_dict(e));
                               return l;
                             })
      .def_property_readonly("fingerprint",
                             [](const PyOptimizer& p) {
                               py::dict d;
                               for (const auto& kv : p.opt->fingerprint()) d[py::str(kv.first)] = kv.second;
                               return d;
                             })
      .def_property_readonly("nonfinite_gradients", [](const PyOptimizer& p) { return p.opt->nonfinite_gradients(); });

  m.def("optimize",
        [](py::object dataset, py::object gaussians, const std::string& out, std::optional<std::string> scene, int iters,
           int spp, int bounces, const std::string& env, std::pair<int, int> env_size, uint64_t seed, bool resume,
           int views_per_iter, int crop, const std::string& loss_space, float lambda_tv, bool optimize_metallic,
           bool optimize_meshes, const std::string& split, std::optional<std::string> prior, std::optional<int> threads,
           int checkpoint_every, py::object callback, std::optional<std::string> env_init, bool fix_env) {
          auto p = make_optimizer(dataset, gaussians, scene, iters, spp, bounces, env, env_size, seed, views_per_iter, crop,
                                  loss_space, lambda_tv, optimize_metallic, optimize_meshes, split, prior, threads, 16,
                                  env_init, fix_env);
          if (resume) {
            std::string ckpt = (std::filesystem::path(out) / "checkpoint.bin").string();
            if (!std::filesystem::exists(ckpt)) throw Error(ckpt, "resume: no checkpoint to continue from");
            py::gil_scoped_release release;
            p->opt->load_checkpoint(ckpt);
          }
          std::string r = run(*p, out, callback, checkpoint_every);
          py::dict d;
          d["result"] = r;
          d["iteration"] = p->opt->iteration();
          py::list l;
          for (const IterationLog& e : p->opt->log()) l.append(log_dict(e));
          d["log"] = l;
          return d;
        },
        py::arg("dataset"), py::arg("gaussians"), py::arg("out"), py::arg("scene") = py::none(), py::arg("iters") = 800,
        py::arg("spp") = 32, py::arg("bounces") = 2, py::arg("env") = "latlong",
        py::arg("env_size") = std::pair<int, int>(128, 64), py::arg("seed") = 0, py::arg("resume") = false,
        py::arg("views_per_iter") = 1, py::arg("crop") = 0, py::arg("loss_space") = "srgb", py::arg("lambda_tv") = 0.095f,
        py::arg("optimize_metallic") = false, py::arg("optimize_meshes") = false, py::arg("split") = "train",
        py::arg("prior") = py::none(), py::arg("threads") = py::none(), py::arg("checkpoint_every") = 50,
        py::arg("callback") = py::none(), py::arg("env_init") = py::none(), py::arg("fix_env") = false,
        "`ptir optimize` from Python: writes out/gaussians.ply, env.exr, log.csv, checkpoint.bin. Returns "
        "{'result': 'finished'|'cancelled', 'iteration': n, 'log': [...]}.");
}
