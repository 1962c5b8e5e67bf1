// Python bindings of the evaluation (src/ptir/eval): the metrics as functions of
// numpy arrays (submodule ptir.metrics) and the whole protocol (ptir.evaluate).
// Images are float32 arrays (H, W, C) or (H, W); masks (H, W), (H, W, 1) or
// (H, W, >= 2) (then the LAST channel, the alpha, is used); foreground = mask > 0.5.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/eval/evaluate.h"
#include "ptir/eval/metrics.h"

namespace py = pybind11;

namespace {

using ptir::Error;
using ptir::Image;
using EvalArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

Image to_image(const EvalArray& a, const char* what) {
  if (a.ndim() != 2 && a.ndim() != 3) throw Error(std::string(what) + " must have shape (h, w) or (h, w, c)");
  int h = int(a.shape(0)), w = int(a.shape(1)), c = a.ndim() == 3 ? int(a.shape(2)) : 1;
  if (h <= 0 || w <= 0 || c <= 0) throw Error(std::string(what) + " is empty");
  std::vector<std::string> names;
  for (int i = 0; i < c; ++i) names.push_back("C" + std::to_string(i));
  Image img(w, h, names);
  std::copy(a.data(), a.data() + img.pixels.size(), img.pixels.begin());
  return img;
}

std::optional<Image> to_mask(const std::optional<EvalArray>& a) {
  if (!a) return std::nullopt;
  Image m = to_image(*a, "mask");
  return m.channels == 1 ? m : ptir::eval::channel_image(m, -1);
}

EvalArray to_array(const Image& img) {
  EvalArray a({py::ssize_t(img.height), py::ssize_t(img.width), py::ssize_t(img.channels)});
  std::copy(img.pixels.begin(), img.pixels.end(), a.mutable_data());
  return a;
}

const Image* ptr(const std::optional<Image>& m) { return m ? &*m : nullptr; }

}  // namespace

namespace {

// mse, psnr, ssim.
void def_image_metrics(py::module_& mm) {
  mm.def(
      "mse",
      [](EvalArray a, EvalArray b, std::optional<EvalArray> mask, int channels) {
        Image x = to_image(a, "a"), y = to_image(b, "b");
        auto mk = to_mask(mask);
        return ptir::eval::mse(x, y, ptr(mk), channels);
      },
      py::arg("a"), py::arg("b"), py::arg("mask") = py::none(), py::arg("channels") = 3,
      "Mean squared difference over the first `channels` channels of the foreground pixels.");
  mm.def(
      "psnr",
      [](EvalArray a, EvalArray b, std::optional<EvalArray> mask, int channels) {
        Image x = to_image(a, "a"), y = to_image(b, "b");
        auto mk = to_mask(mask);
        return ptir::eval::psnr(x, y, ptr(mk), channels);
      },
      py::arg("a"), py::arg("b"), py::arg("mask") = py::none(), py::arg("channels") = 3,
      "PSNR (data range 1) over the foreground pixels; inf for identical images.");
  mm.def(
      "ssim",
      [](EvalArray a, EvalArray b) { return ptir::eval::ssim(to_image(a, "a"), to_image(b, "b")); }, py::arg("a"),
      py::arg("b"),
      "Mean SSIM over 3 channels (Gaussian 11x11 window, sigma 1.5, data range 1): "
      "skimage.metrics.structural_similarity(..., gaussian_weights=True, sigma=1.5, use_sample_covariance=False, "
      "data_range=1, channel_axis=2).");
}

// The protocol's pieces: median, albedo scale, normal MAE, roughness MSE, display composite.
void def_protocol_metrics(py::module_& mm) {
  mm.def(
      "median", [](std::vector<float> v) { return ptir::eval::median(v); }, py::arg("values"));
  mm.def(
      "albedo_scale",
      [](std::vector<EvalArray> gt, std::vector<EvalArray> pred, std::vector<std::optional<EvalArray>> masks) {
        if (gt.size() != pred.size() || gt.size() != masks.size())
          throw Error("albedo_scale: need as many ground-truth, predicted and mask images");
        std::vector<Image> g, p;
        std::vector<std::optional<Image>> k;
        for (size_t i = 0; i < gt.size(); ++i) {
          g.push_back(to_image(gt[i], "gt"));
          p.push_back(to_image(pred[i], "pred"));
          k.push_back(to_mask(masks[i]));
        }
        std::vector<const Image*> gp, pp, kp;
        for (size_t i = 0; i < gt.size(); ++i) {
          gp.push_back(&g[i]);
          pp.push_back(&p[i]);
          kp.push_back(ptr(k[i]));
        }
        std::array<double, 3> s = ptir::eval::albedo_scale(gp, pp, kp);
        return py::make_tuple(s[0], s[1], s[2]);
      },
      py::arg("gt"), py::arg("pred"), py::arg("masks"),
      "Per-channel median of gt / max(pred, 1e-6) over the foreground pixels of all views.");
  mm.def(
      "apply_scale",
      [](EvalArray pred, std::array<double, 3> s) { return to_array(ptir::eval::apply_scale(to_image(pred, "pred"), s)); },
      py::arg("pred"), py::arg("scale"), "pred * scale clamped to [0, 1] (3 channels).");
  mm.def(
      "normal_mae",
      [](EvalArray gt, EvalArray pred, std::optional<EvalArray> mask) {
        Image g = to_image(gt, "gt"), p = to_image(pred, "pred");
        auto mk = to_mask(mask);
        return ptir::eval::normal_mae_deg(g, p, ptr(mk));
      },
      py::arg("gt"), py::arg("pred"), py::arg("mask") = py::none(),
      "Mean angle in degrees over foreground pixels (zero predictions count as 90).");
  mm.def(
      "roughness_mse",
      [](EvalArray gt, EvalArray pred, std::optional<EvalArray> mask) {
        Image g = to_image(gt, "gt"), p = to_image(pred, "pred");
        auto mk = to_mask(mask);
        return ptir::eval::roughness_mse(g, p, ptr(mk));
      },
      py::arg("gt"), py::arg("pred"), py::arg("mask") = py::none(),
      "MSE of the first channel over the whole image with the background zeroed.");
  mm.def(
      "composite_srgb",
      [](EvalArray rgb, std::optional<EvalArray> alpha, std::array<float, 3> bg) {
        Image c = to_image(rgb, "rgb");
        std::optional<Image> a;
        if (alpha) a = to_image(*alpha, "alpha");
        return to_array(ptir::eval::composite_srgb(c, ptr(a), ptir::Vec3(bg[0], bg[1], bg[2])));
      },
      py::arg("rgb"), py::arg("alpha") = py::none(), py::arg("background") = std::array<float, 3>{1.0f, 1.0f, 1.0f},
      "srgb(clamp(rgb)) * alpha + background * (1 - alpha) (alpha: its last channel).");

}

// ptir.evaluate: the whole protocol (`ptir eval`).
void def_evaluate(py::module_& m) {
  m.def(
      "evaluate",
      [](const std::string& dataset, const std::string& result, std::map<std::string, std::string> relight, int spp,
         int bounces, int aov_spp, const std::string& split, const std::string& scene, uint64_t seed, int sheet_views,
         std::function<void(const std::string&)> log) {
        ptir::eval::EvalSettings s;
        s.dataset = dataset;
        s.result = result;
        for (const auto& [name, path] : relight) s.relight.push_back(ptir::eval::parse_relight(name + "=" + path));
        s.spp = spp;
        s.bounces = bounces;
        s.aov_spp = aov_spp;
        s.split = split;
        s.scene = scene;
        s.seed = seed;
        s.sheet_views = sheet_views;
        if (log)
          s.log = [log](const std::string& line) {
            py::gil_scoped_acquire gil;
            log(line);
          };
        ptir::eval::EvalReport r;
        {
          py::gil_scoped_release release;
          r = ptir::eval::evaluate(s);
        }
        return py::module_::import("json").attr("loads")(r.metrics.dump());
      },
      py::arg("dataset"), py::arg("result"), py::arg("relight") = std::map<std::string, std::string>{},
      py::arg("spp") = 64, py::arg("bounces") = 4, py::arg("aov_spp") = 16, py::arg("split") = "test",
      py::arg("scene") = "", py::arg("seed") = 0, py::arg("sheet_views") = 8, py::arg("log") = nullptr,
      "Runs `ptir eval` (writes RESULT/eval/) and returns metrics.json as a dict.");
}

}  // namespace

void bind_eval(py::module_& m) {
  py::module_ mm = m.def_submodule("metrics", "Evaluation metrics (docs/method.md §7) on numpy images");
  def_image_metrics(mm);
  def_protocol_metrics(mm);
  def_evaluate(m);
}
