#include "ptir/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "ptir/core/error.h"
#include "ptir/optim/losses.h"

namespace ptir::eval {

namespace {

void check_same_size(const Image& a, const Image& b, const char* what) {
  if (a.width != b.width || a.height != b.height)
    throw Error(std::string(what) + ": image sizes differ (" + std::to_string(a.width) + "x" + std::to_string(a.height) +
                " vs " + std::to_string(b.width) + "x" + std::to_string(b.height) + ")");
}

void check_mask(const Image& img, const Image* mask, const char* what) {
  if (!mask) return;
  check_same_size(img, *mask, what);
  if (mask->channels < 1) throw Error(std::string(what) + ": mask has no channel");
}

void check_channels(const Image& img, int n, const char* what) {
  if (img.channels < n)
    throw Error(std::string(what) + ": needs " + std::to_string(n) + " channels, the image has " +
                std::to_string(img.channels));
}

bool foreground(const Image* mask, int x, int y) { return !mask || mask->at(x, y, 0) > 0.5f; }

}  // namespace

double median(std::vector<float>& v) {
  if (v.empty()) throw Error("median of no values");
  const size_t n = v.size();
  std::nth_element(v.begin(), v.begin() + n / 2, v.end());
  double hi = v[n / 2];
  if (n % 2 == 1) return hi;
  double lo = *std::max_element(v.begin(), v.begin() + n / 2);
  return 0.5 * (lo + hi);
}

double mse(const Image& a, const Image& b, const Image* mask, int channels) {
  check_same_size(a, b, "mse");
  check_channels(a, channels, "mse");
  check_channels(b, channels, "mse");
  check_mask(a, mask, "mse");
  double sum = 0.0;
  size_t n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      if (!foreground(mask, x, y)) continue;
      for (int c = 0; c < channels; ++c) {
        double d = double(a.at(x, y, c)) - double(b.at(x, y, c));
        sum += d * d;
      }
      n += size_t(channels);
    }
  return n ? sum / double(n) : 0.0;
}

double psnr_from_mse(double m, double peak) {
  if (m <= 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(peak * peak / m);
}

double psnr(const Image& a, const Image& b, const Image* mask, int channels) {
  return psnr_from_mse(mse(a, b, mask, channels));
}

double ssim(const Image& a, const Image& b) {
  check_same_size(a, b, "ssim");
  check_channels(a, 3, "ssim");
  check_channels(b, 3, "ssim");
  auto rgb = [](const Image& img) {
    if (img.channels == 3) return img;
    Image out(img.width, img.height, {"R", "G", "B"});
    for (size_t i = 0, n = size_t(img.width) * img.height; i < n; ++i)
      for (int c = 0; c < 3; ++c) out.pixels[i * 3 + c] = img.pixels[i * img.channels + c];
    return out;
  };
  return ptir::ssim(rgb(a), rgb(b), nullptr);
}

std::array<double, 3> albedo_scale(const std::vector<const Image*>& gt, const std::vector<const Image*>& pred,
                                   const std::vector<const Image*>& masks) {
  if (gt.size() != pred.size() || gt.size() != masks.size())
    throw Error("albedo_scale: need as many ground-truth, predicted and mask images");
  std::array<std::vector<float>, 3> ratios;
  for (size_t v = 0; v < gt.size(); ++v) {
    const Image& g = *gt[v];
    const Image& p = *pred[v];
    check_same_size(g, p, "albedo_scale");
    check_channels(g, 3, "albedo_scale ground truth");
    check_channels(p, 3, "albedo_scale prediction");
    check_mask(g, masks[v], "albedo_scale");
    for (int y = 0; y < g.height; ++y)
      for (int x = 0; x < g.width; ++x) {
        if (!foreground(masks[v], x, y)) continue;
        for (int c = 0; c < 3; ++c) ratios[c].push_back(g.at(x, y, c) / std::max(p.at(x, y, c), 1e-6f));
      }
  }
  std::array<double, 3> s{1.0, 1.0, 1.0};
  for (int c = 0; c < 3; ++c)
    if (!ratios[c].empty()) s[c] = median(ratios[c]);
  return s;
}

void AlbedoRatios::add(const Image& gt, const Image& pred, const Image& mask) {
  check_same_size(gt, pred, "albedo scale");
  for (int y = 0; y < gt.height; ++y)
    for (int x = 0; x < gt.width; ++x) {
      if (mask.at(x, y, 0) <= 0.5f) continue;
      for (int c = 0; c < 3; ++c)
        if (pred.at(x, y, c) > kAlbedoScaleBlack && gt.at(x, y, c) > kAlbedoScaleBlack)
          ratios[c].push_back(gt.at(x, y, c) / pred.at(x, y, c));
    }
}

std::array<double, 3> AlbedoRatios::scale() {
  std::array<double, 3> s{1.0, 1.0, 1.0};
  for (int c = 0; c < 3; ++c)
    if (!ratios[c].empty()) s[c] = median(ratios[c]);
  return s;
}

Image apply_scale(const Image& pred, const std::array<double, 3>& s) {
  check_channels(pred, 3, "apply_scale");
  Image out(pred.width, pred.height, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(pred.width) * pred.height; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      out.pixels[i * 3 + c] = float(std::clamp(double(pred.pixels[i * pred.channels + c]) * s[c], 0.0, 1.0));
  return out;
}

double normal_mae_deg(const Image& gt, const Image& pred, const Image* mask) {
  check_same_size(gt, pred, "normal_mae");
  check_channels(gt, 3, "normal_mae ground truth");
  check_channels(pred, 3, "normal_mae prediction");
  check_mask(gt, mask, "normal_mae");
  double sum = 0.0;
  size_t n = 0;
  for (int y = 0; y < gt.height; ++y)
    for (int x = 0; x < gt.width; ++x) {
      if (!foreground(mask, x, y)) continue;
      double g[3], p[3], lg = 0.0, lp = 0.0;
      for (int c = 0; c < 3; ++c) {
        g[c] = gt.at(x, y, c);
        p[c] = pred.at(x, y, c);
        lg += g[c] * g[c];
        lp += p[c] * p[c];
      }
      if (lg <= 1e-12) continue;  // no ground truth here
      double angle = 90.0;
      if (lp > 1e-12) {
        double d = (g[0] * p[0] + g[1] * p[1] + g[2] * p[2]) / std::sqrt(lg * lp);
        angle = std::acos(std::clamp(d, -1.0, 1.0)) * (180.0 / 3.14159265358979323846);
      }
      sum += angle;
      ++n;
    }
  return n ? sum / double(n) : 0.0;
}

double roughness_mse(const Image& gt, const Image& pred, const Image* mask) {
  check_same_size(gt, pred, "roughness_mse");
  check_channels(gt, 1, "roughness_mse ground truth");
  check_channels(pred, 1, "roughness_mse prediction");
  check_mask(gt, mask, "roughness_mse");
  double sum = 0.0;
  for (int y = 0; y < gt.height; ++y)
    for (int x = 0; x < gt.width; ++x) {
      if (!foreground(mask, x, y)) continue;  // background: both zeroed, difference 0
      double d = double(gt.at(x, y, 0)) - double(pred.at(x, y, 0));
      sum += d * d;
    }
  return sum / double(size_t(gt.width) * gt.height);
}

Image channel_image(const Image& img, int c) {
  if (img.channels < 1) throw Error("channel_image: image has no channel");
  if (c < 0) c = img.channels - 1;
  if (c >= img.channels) throw Error("channel_image: channel " + std::to_string(c) + " out of range");
  Image out(img.width, img.height, {"Y"});
  for (size_t i = 0, n = size_t(img.width) * img.height; i < n; ++i) out.pixels[i] = img.pixels[i * img.channels + c];
  return out;
}

Image composite_srgb(const Image& rgb, const Image* alpha, Vec3 background) {
  check_channels(rgb, 3, "composite_srgb");
  if (alpha) check_same_size(rgb, *alpha, "composite_srgb");
  Image out(rgb.width, rgb.height, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(rgb.width) * rgb.height; i < n; ++i) {
    float a = alpha ? std::clamp(alpha->pixels[i * alpha->channels + (alpha->channels - 1)], 0.0f, 1.0f) : 1.0f;
    for (int c = 0; c < 3; ++c) {
      float v = linear_to_srgb(std::clamp(rgb.pixels[i * rgb.channels + c], 0.0f, 1.0f));
      out.pixels[i * 3 + c] = v * a + background[c] * (1.0f - a);
    }
  }
  return out;
}

Image unpremultiply(const Image& rgba) {
  check_channels(rgba, 4, "unpremultiply");
  Image out(rgba.width, rgba.height, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(rgba.width) * rgba.height; i < n; ++i) {
    float a = rgba.pixels[i * rgba.channels + 3];
    for (int c = 0; c < 3; ++c) out.pixels[i * 3 + c] = a > 1e-6f ? rgba.pixels[i * rgba.channels + c] / a : 0.0f;
  }
  return out;
}

Image srgb_encode(const Image& linear) {
  check_channels(linear, 3, "srgb_encode");
  Image out(linear.width, linear.height, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(linear.width) * linear.height; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      out.pixels[i * 3 + c] = linear_to_srgb(std::clamp(linear.pixels[i * linear.channels + c], 0.0f, 1.0f));
  return out;
}

}  // namespace ptir::eval
