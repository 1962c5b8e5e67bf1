// Python bindings of the image objectives (optim/losses.h). Images are numpy
// float32 arrays (H, W, C) (a 2D (H, W) array is one channel); masks are
// (H, W), (H, W, 1) or (H, W, >=4) (then channel 3, the alpha, is used).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/optim/losses.h"

namespace py = pybind11;

namespace {

using ptir::Error;
using ptir::Image;
using LossArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

Image to_image(const LossArray& a, const char* what) {
  if (a.ndim() != 2 && a.ndim() != 3) throw Error(std::string(what) + " must have shape (h, w) or (h, w, c)");
  int h = int(a.shape(0)), w = int(a.shape(1)), c = a.ndim() == 3 ? int(a.shape(2)) : 1;
  if (h <= 0 || w <= 0 || c <= 0) throw Error(std::string(what) + " is empty");
  static const char* rgba[] = {"R", "G", "B", "A"};
  std::vector<std::string> names;
  if (c == 1) names = {"Y"};
  else for (int i = 0; i < c; ++i) names.push_back(c <= 4 ? std::string(rgba[i]) : "C" + std::to_string(i));
  Image img(w, h, names);
  std::copy(a.data(), a.data() + img.pixels.size(), img.pixels.begin());
  return img;
}

std::optional<Image> to_mask(const std::optional<LossArray>& a) {
  if (!a) return std::nullopt;
  return to_image(*a, "mask");
}

LossArray to_array(const Image& img) {
  LossArray a({py::ssize_t(img.height), py::ssize_t(img.width), py::ssize_t(img.channels)});
  std::copy(img.pixels.begin(), img.pixels.end(), a.mutable_data());
  return a;
}

}  // namespace

void bind_losses(py::module_& m) {
  m.def(
      "image_loss",
      [](LossArray pred, LossArray target, std::optional<LossArray> mask, float lambda_ssim, bool binomial) {
        Image p = to_image(pred, "pred"), t = to_image(target, "target");
        std::optional<Image> mk = to_mask(mask);
        ptir::ImageLossSettings s;
        s.lambda_ssim = lambda_ssim;
        s.binomial_filter = binomial;
        Image d;
        double loss;
        {
          py::gil_scoped_release release;
          loss = ptir::image_loss(p, t, mk ? &*mk : nullptr, s, &d);
        }
        return py::make_tuple(loss, to_array(d));
      },
      py::arg("pred"), py::arg("target"), py::arg("mask") = py::none(), py::arg("lambda_ssim") = 0.2f,
      py::arg("binomial") = true,
      "(1 - lambda) * masked mean L1 + lambda * (1 - masked mean SSIM) of blur(pred) against target, first 3 "
      "channels. Returns (loss, d_pred) with d_pred float32 (h, w, 3), the exact gradient w.r.t. pred.");
  m.def(
      "ssim",
      [](LossArray a, LossArray b, std::optional<LossArray> mask) {
        Image ia = to_image(a, "a"), ib = to_image(b, "b");
        std::optional<Image> mk = to_mask(mask);
        py::gil_scoped_release release;
        return ptir::ssim(ia, ib, mk ? &*mk : nullptr);
      },
      py::arg("a"), py::arg("b"), py::arg("mask") = py::none(),
      "Mean SSIM over the first 3 channels (scikit-image's structural_similarity with gaussian_weights=True, "
      "sigma=1.5, use_sample_covariance=False, data_range=1), optionally mask-weighted.");
  m.def(
      "binomial_filter",
      [](LossArray img) {
        Image i = to_image(img, "image");
        Image out;
        {
          py::gil_scoped_release release;
          out = ptir::binomial_filter(i);
        }
        return to_array(out);
      },
      py::arg("image"), "3x3 normalised binomial blur ([1 2 1]^T [1 2 1] / 16, edges clamped) of every channel.");
  m.def(
      "edge_aware_tv",
      [](LossArray map, LossArray guide, std::optional<LossArray> mask) {
        Image mp = to_image(map, "map"), g = to_image(guide, "guide");
        std::optional<Image> mk = to_mask(mask);
        Image d;
        double v;
        {
          py::gil_scoped_release release;
          v = ptir::edge_aware_tv(mp, g, mk ? &*mk : nullptr, &d);
        }
        return py::make_tuple(v, to_array(d));
      },
      py::arg("map"), py::arg("guide"), py::arg("mask") = py::none(),
      "Edge-aware TV of a material map guided by the ground-truth image; returns (value, d_map).");
  m.def(
      "prior_l2",
      [](LossArray map, LossArray prior, std::optional<LossArray> mask) {
        Image mp = to_image(map, "map"), pr = to_image(prior, "prior");
        std::optional<Image> mk = to_mask(mask);
        Image d;
        double v;
        {
          py::gil_scoped_release release;
          v = ptir::prior_l2(mp, pr, mk ? &*mk : nullptr, &d);
        }
        return py::make_tuple(v, to_array(d));
      },
      py::arg("map"), py::arg("prior"), py::arg("mask") = py::none(),
      "Masked mean squared difference to a prior map; returns (value, d_map).");
}
