#include "ptir/eval/env_score.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "ptir/eval/contact_sheet.h"

namespace ptir::eval {

namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Bilinear lookup at continuous texel coordinates (u wraps, v clamps).
float bilinear(const Image& img, float x, float y, int c) {
  x -= 0.5f;
  y = std::clamp(y - 0.5f, 0.0f, float(img.height - 1));
  const int x0 = int(std::floor(x)), y0 = int(y);
  const float fx = x - float(x0), fy = y - float(y0);
  auto at = [&](int xi, int yi) {
    xi = ((xi % img.width) + img.width) % img.width;
    yi = std::min(yi, img.height - 1);
    return img.pixels[(size_t(yi) * img.width + xi) * img.channels + c];
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

float display(float x) { return linear_to_srgb(std::max(x, 0.0f) / (1.0f + std::max(x, 0.0f))); }

double psnr_of(double sum_sq, double weight) { return sum_sq > 0.0 ? -10.0 * std::log10(sum_sq / weight) : 100.0; }

}  // namespace

EnvScore score_environment(const Image& ours_in, const Image& gt) {
  const int W = gt.width, H = gt.height;
  Image ours(W, H, {"R", "G", "B"});
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c)
        ours.pixels[(size_t(y) * W + x) * 3 + c] =
            bilinear(ours_in, (float(x) + 0.5f) * ours_in.width / W, (float(y) + 0.5f) * ours_in.height / H, std::min(c, ours_in.channels - 1));
  // Solid angle of a row: proportional to sin(theta) at the row centre.
  std::vector<double> w(H);
  for (int y = 0; y < H; ++y) w[y] = std::sin(kPi * (double(y) + 0.5) / H);
  EnvScore s;
  std::array<double, 3> sum_gt{}, sum_ours{};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < 3; ++c) {
        sum_gt[c] += w[y] * gt.pixels[(size_t(y) * W + x) * gt.channels + c];
        sum_ours[c] += w[y] * ours.pixels[(size_t(y) * W + x) * 3 + c];
      }
  for (int c = 0; c < 3; ++c) s.scale[c] = sum_ours[c] > 0.0 ? sum_gt[c] / sum_ours[c] : 1.0;
  Image d_gt(W, H, {"R", "G", "B"}), d_ours(W, H, {"R", "G", "B"});
  double sq = 0.0, sq_up = 0.0, wsum = 0.0, wsum_up = 0.0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t p = size_t(y) * W + x;
      double e = 0.0;
      for (int c = 0; c < 3; ++c) {
        d_gt.pixels[p * 3 + c] = display(gt.pixels[p * gt.channels + c]);
        d_ours.pixels[p * 3 + c] = display(float(s.scale[c]) * ours.pixels[p * 3 + c]);
        const double d = double(d_gt.pixels[p * 3 + c]) - double(d_ours.pixels[p * 3 + c]);
        e += d * d / 3.0;
      }
      sq += w[y] * e;
      wsum += w[y];
      if (2 * y < H) {  // the top half of a Blender lat-long is z >= 0
        sq_up += w[y] * e;
        wsum_up += w[y];
      }
    }
  s.psnr = psnr_of(sq, wsum);
  s.psnr_upper = psnr_of(sq_up, wsum_up);
  s.sheet = contact_sheet({{d_gt}, {d_ours}, {heatmap(abs_difference(d_gt, d_ours), 0.25f)}}, std::max(1, 512 / W));
  return s;
}

std::string dataset_training_environment(const std::string& dataset_dir) {
  const fs::path meta = fs::path(dataset_dir) / "dataset.json";
  std::ifstream in(meta);
  if (!in) return "";
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object() || !j.contains("train_env") || !j["train_env"].is_string() || !j.contains("envmaps") ||
      !j["envmaps"].is_object())
    return "";
  const std::string name = j["train_env"].get<std::string>();
  if (!j["envmaps"].contains(name) || !j["envmaps"][name].is_string()) return "";
  const fs::path p = fs::path(dataset_dir) / j["envmaps"][name].get<std::string>();
  return fs::exists(p) ? p.string() : "";
}

}  // namespace ptir::eval
