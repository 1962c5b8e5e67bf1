// Python binding of the optimise pipeline (src/ptir/pipeline/optimize_pipeline.h):
// the stages, budget, resume and outputs of `ptir optimize`, run in this process.
//
//   status = ptir.optimize_pipeline(dataset="DIR", gaussians="in.ply", out="OUT", iters=400, fit_iters=0,
//                                   threads=1, progress_callback=lambda event: True)   # "finished" | "cancelled"
//
// Every keyword is a `ptir optimize` option, spelt with "_" for "-" (--fit-iters:
// fit_iters; --progress: progress="text"|"json"), with its default; the same
// options give the same outputs as the command line. progress_callback(event)
// receives each progress event as a dict (the JSON objects of --progress json,
// docs/engine_protocol.md) and may return False to stop after the current
// iteration (the checkpoint and the outputs are written: "cancelled"). The GIL is
// released while the pipeline runs; the callback runs with it held. An exception
// the callback raises stops the run the same way and is raised again afterwards.
// Bad input raises ptir.Error; a missing dataset and splats, ValueError.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <type_traits>

#include "ptir/core/communicator.h"
#include "ptir/pipeline/optimize_pipeline.h"

namespace py = pybind11;
using ptir::pipeline::OptimizePipelineOptions;

namespace {

using Setter = std::function<void(OptimizePipelineOptions&, py::handle)>;

// A value for a field of type T: paths (os.PathLike) as their text.
template <class T>
T value_of(py::handle v) {
  if constexpr (std::is_same_v<T, std::string>) {
    if (!py::isinstance<py::str>(v) && py::hasattr(v, "__fspath__"))
      return py::str(py::module_::import("os").attr("fspath")(v)).cast<std::string>();
  }
  return v.cast<T>();
}

template <class Ref>
Setter setter(Ref ref) {
  return [ref](OptimizePipelineOptions& o, py::handle v) {
    auto& field = ref(o);
    field = value_of<std::remove_reference_t<decltype(field)>>(v);
  };
}

#define PTIR_OPTION(name, member) {name, setter([](OptimizePipelineOptions& o) -> auto& { return o.member; })}

// The keywords: `ptir optimize`'s options (cli/cmd_optimize.cpp, cli/optimize_flags.cpp and the shared groups).
const std::map<std::string, Setter>& options_by_keyword() {
  static const std::map<std::string, Setter> table = {
      PTIR_OPTION("dataset", dataset), PTIR_OPTION("gaussians", gaussians), PTIR_OPTION("scene", scene),
      PTIR_OPTION("out", out), PTIR_OPTION("fit_iters", fit_iters), PTIR_OPTION("subject", subject),
      PTIR_OPTION("iters", opt.iters), PTIR_OPTION("spp", opt.spp), PTIR_OPTION("bounces", opt.bounces),
      PTIR_OPTION("indirect", opt.indirect), PTIR_OPTION("env", opt.env), PTIR_OPTION("env_size", env_size),
      PTIR_OPTION("env_init", opt.env_init), PTIR_OPTION("fix_env", opt.fix_env),
      PTIR_OPTION("fix_env_seen", opt.fix_env_seen), PTIR_OPTION("background_loss", opt.background_loss),
      PTIR_OPTION("env_seen", opt.env_seen),
      PTIR_OPTION("object_patch_share", opt.object_patch_share), PTIR_OPTION("env_align", opt.env_align),
      PTIR_OPTION("env_refine", opt.env_refine), PTIR_OPTION("seed", opt.seed), PTIR_OPTION("brdf", brdf),
      PTIR_OPTION("resume", resume), PTIR_OPTION("split", split), PTIR_OPTION("prior", prior),
      PTIR_OPTION("views_per_iter", opt.views_per_iter), PTIR_OPTION("crop", opt.crop),
      PTIR_OPTION("coarse_pixels", opt.coarse_pixels), PTIR_OPTION("fine_fraction", opt.fine_fraction),
      PTIR_OPTION("coarse_spp", opt.coarse_spp), PTIR_OPTION("checkpoint_every", checkpoint_every),
      PTIR_OPTION("threads", threads), PTIR_OPTION("loss_space", opt.loss_space), PTIR_OPTION("lambda_tv", opt.lambda_tv),
      PTIR_OPTION("tv_chroma", opt.tv_chroma),
      PTIR_OPTION("lr_final", opt.lr_final), PTIR_OPTION("lr_decay_start", opt.lr_decay_start),
      PTIR_OPTION("sample_cache_mb", opt.sample_cache_mb), PTIR_OPTION("env_coarse", opt.env_coarse),
      PTIR_OPTION("albedo_warmup", opt.albedo_warmup), PTIR_OPTION("tv_warmup", opt.tv_warmup),
      PTIR_OPTION("init_albedo", opt.init_albedo), PTIR_OPTION("init_from_ply", opt.init_from_ply),
      PTIR_OPTION("light_balance", opt.light_balance), PTIR_OPTION("decorrelate_adjoint", opt.decorrelate_adjoint),
      PTIR_OPTION("lambda_ssim", opt.lambda_ssim), PTIR_OPTION("loss_blur", opt.loss_blur),
      PTIR_OPTION("loss_blur_target", opt.loss_blur_target), PTIR_OPTION("lr_balance", opt.lr_balance),
      PTIR_OPTION("lambda_albedo_grey", opt.lambda_albedo_grey), PTIR_OPTION("balance_start", opt.balance_start),
      PTIR_OPTION("lr_env", opt.lr_env), PTIR_OPTION("lr_albedo", opt.lr_albedo), PTIR_OPTION("lr_metallic", opt.lr_metallic),
      PTIR_OPTION("lr_roughness", opt.lr_roughness), PTIR_OPTION("env_fine_rate", opt.env_fine_rate),
      PTIR_OPTION("neutral_light", opt.neutral_light), PTIR_OPTION("optimize_metallic", opt.optimize_metallic),
      PTIR_OPTION("optimize_meshes", opt.optimize_meshes), PTIR_OPTION("learn_exposure", opt.learn_exposure),
      PTIR_OPTION("quiet", quiet), PTIR_OPTION("budget", budget), PTIR_OPTION("estimate", estimate),
      PTIR_OPTION("force", force), PTIR_OPTION("layout", capture.layout), PTIR_OPTION("images", capture.images),
      PTIR_OPTION("holdout", capture.holdout), PTIR_OPTION("test_list", capture.test_list),
      PTIR_OPTION("max_image_side", capture.max_image_side),
      PTIR_OPTION("undistort_cache", capture.undistort_cache),
      PTIR_OPTION("dataparser_transforms", capture.dataparser_transforms), PTIR_OPTION("world", capture.world),
      PTIR_OPTION("black_background", capture.black_background), PTIR_OPTION("ignore_exif", capture.ignore_exif),
      PTIR_OPTION("calibration", capture.calibration), PTIR_OPTION("pixel_filter", filter.type),
      PTIR_OPTION("filter_width", filter.width), PTIR_OPTION("cameras", radiance.cameras),
      PTIR_OPTION("up", radiance.up), PTIR_OPTION("orbit_views", radiance.orbit.views),
      PTIR_OPTION("orbit_size", radiance.orbit.size), PTIR_OPTION("orbit_elevation", radiance.orbit.elevation_min),
      PTIR_OPTION("orbit_elevation_max", radiance.orbit.elevation_max), PTIR_OPTION("orbit_fov", radiance.orbit.fov_deg),
      PTIR_OPTION("orbit_distance", radiance.orbit.distance_scale), PTIR_OPTION("target_spp", radiance.target_spp),
      {"progress", [](OptimizePipelineOptions& o, py::handle v) {
         o.progress_format = ptir::pipeline::parse_progress_format(v.cast<std::string>());
       }}};
  return table;
}

#undef PTIR_OPTION

// "fit_iters" -> "--fit-iters": the name the pipeline's given options use.
std::string flag_name(std::string keyword) {
  for (char& c : keyword)
    if (c == '_') c = '-';
  return "--" + keyword;
}

std::string optimize_pipeline(py::object progress_callback, py::kwargs kwargs) {
  OptimizePipelineOptions o;
  for (const auto& item : kwargs) {
    const std::string key = item.first.cast<std::string>();
    const auto it = options_by_keyword().find(key);
    if (it == options_by_keyword().end())
      throw py::type_error("optimize_pipeline() got an unexpected keyword argument '" + key +
                           "' (the options are `ptir optimize`'s, with _ for -)");
    if (item.second.is_none()) continue;  // None: the default
    it->second(o, item.second);
    o.given.insert(flag_name(key));
  }
  std::optional<py::error_already_set> raised;  // the callback's exception, raised after the run
  ptir::pipeline::ProgressCallback on_progress;
  if (!progress_callback.is_none())
    on_progress = [&](const nlohmann::ordered_json& event) {
      py::gil_scoped_acquire gil;
      if (raised) return false;
      try {
        const py::object r = progress_callback(py::module_::import("json").attr("loads")(event.dump()));
        return !(py::isinstance<py::bool_>(r) && !r.cast<bool>());
      } catch (py::error_already_set& e) {
        raised = std::move(e);
        return false;
      }
    };
  int rc = 0;
  {
    py::gil_scoped_release release;
    rc = ptir::pipeline::run_optimize_pipeline(o, ptir::single_process(), on_progress);
  }
  if (raised) throw std::move(*raised);
  if (rc == 2) throw py::value_error("optimize_pipeline: give dataset (photos and poses) or gaussians (a splat PLY), or both");
  return rc == 130 ? "cancelled" : "finished";
}

}  // namespace

void bind_pipeline(py::module_& m) {
  m.def("optimize_pipeline", &optimize_pipeline, py::arg("progress_callback") = py::none(),
        "Run the optimise pipeline of `ptir optimize` (capture, geometry and radiance stages, the inversion, "
        "budget, resume, outputs) in this process. Keywords: the command's options with _ for - "
        "(out='OUT', dataset=..., gaussians=..., fit_iters=..., iters=..., threads=...). "
        "progress_callback(event: dict) receives the progress events (--progress json's objects); returning "
        "False stops after the current iteration. Returns 'finished' or 'cancelled'.");
}
