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
#include "ptir/optim/optimizer_setup.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene.h"
#include "py_arrays.h"

namespace py = pybind11;
using namespace ptir;
using namespace ptir::py_bind;

namespace {

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
                                            bool fix_env, const std::string& indirect, const std::string& env_align) {
  OptimizeOptions o;
  o.iters = iters;
  o.spp = spp;
  o.bounces = bounces;
  o.indirect = indirect;
  o.seed = seed;
  o.views_per_iter = views_per_iter;
  o.crop = crop;
  o.loss_space = loss_space;
  o.lambda_tv = lambda_tv;
  o.env = env;
  o.env_width = env_size.first;
  o.env_height = env_size.second;
  o.env_init = env_init ? *env_init : "";
  o.fix_env = fix_env;
  o.env_align = env_align;
  o.optimize_metallic = optimize_metallic;
  o.optimize_meshes = optimize_meshes;
  o.k = k;
  OptimizerSettings s = optimizer_settings(o, python_option_name);
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
  Scene scene = prepare_optimizer_scene(scene_path ? *scene_path : "", field, s, python_option_name);
  if (!scene_path) scene.source_path = "python";
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

void bind_dataset(py::module_& m);  // bind_dataset.cpp

namespace {

void def_optimizer_class(py::module_& m) {
  py::class_<PyOptimizer>(m, "Optimizer",
                          "The inverse-rendering optimiser (the loop of `ptir optimize`): Adam on per-Gaussian albedo, "
                          "roughness (and optionally metallic) and the environment, gradients by path replay.")
      .def(py::init(&make_optimizer), py::arg("dataset"), py::arg("gaussians"), py::arg("scene") = py::none(),
           py::arg("iters") = 800, py::arg("spp") = 32, py::arg("bounces") = 2, py::arg("env") = "latlong",
           py::arg("env_size") = std::pair<int, int>(128, 64), py::arg("seed") = 0, py::arg("views_per_iter") = 1,
           py::arg("crop") = 0, py::arg("loss_space") = "srgb-blur-first", py::arg("lambda_tv") = 0.095f,
           py::arg("optimize_metallic") = false, py::arg("optimize_meshes") = false, py::arg("split") = "train",
           py::arg("prior") = py::none(), py::arg("threads") = py::none(), py::arg("k") = 16,
           py::arg("env_init") = py::none(), py::arg("fix_env") = false, py::arg("indirect") = "path",
           py::arg("env_align") = "auto")
      .def_property_readonly("iteration", [](const PyOptimizer& p) { return p.opt->iteration(); })
      .def_property_readonly(
          "env_alignment",
          [](const PyOptimizer& p) -> py::object {
            if (p.opt->env_alignment().mode == EnvAlignMode::Off) return py::none();
            return py::module_::import("json").attr("loads")(p.opt->env_alignment().json());
          },
          "what lining the env_init map up with the photos found (yaw_deg, scale, candidates...; "
          "OUT/settings.json 'env_align'), or None")
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

}

void def_optimize_function(py::module_& m) {
  m.def("optimize",
        [](py::object dataset, py::object gaussians, const std::string& out, std::optional<std::string> scene, int iters,
           int spp, int bounces, const std::string& env, std::pair<int, int> env_size, uint64_t seed, bool resume,
           int views_per_iter, int crop, const std::string& loss_space, float lambda_tv, bool optimize_metallic,
           bool optimize_meshes, const std::string& split, std::optional<std::string> prior, std::optional<int> threads,
           int checkpoint_every, py::object callback, std::optional<std::string> env_init, bool fix_env,
           const std::string& indirect, const std::string& env_align) {
          auto p = make_optimizer(dataset, gaussians, scene, iters, spp, bounces, env, env_size, seed, views_per_iter, crop,
                                  loss_space, lambda_tv, optimize_metallic, optimize_meshes, split, prior, threads, 16,
                                  env_init, fix_env, indirect, env_align);
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
        py::arg("views_per_iter") = 1, py::arg("crop") = 0, py::arg("loss_space") = "srgb-blur-first", py::arg("lambda_tv") = 0.095f,
        py::arg("optimize_metallic") = false, py::arg("optimize_meshes") = false, py::arg("split") = "train",
        py::arg("prior") = py::none(), py::arg("threads") = py::none(), py::arg("checkpoint_every") = 50,
        py::arg("callback") = py::none(), py::arg("env_init") = py::none(), py::arg("fix_env") = false,
        py::arg("indirect") = "path", py::arg("env_align") = "auto",
        "`ptir optimize` from Python (no geometry stage: `indirect` 'field' takes the bounce light from the splats' SH, "
        "right when they were fitted to these photos): writes out/gaussians.ply, env.exr, log.csv, checkpoint.bin. Returns "
        "{'result': 'finished'|'cancelled', 'iteration': n, 'log': [...]}.");
}

}  // namespace

void bind_optimize(py::module_& m) {
  bind_dataset(m);
  def_optimizer_class(m);
  def_optimize_function(m);
}
