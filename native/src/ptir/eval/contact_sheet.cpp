#include "ptir/eval/contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "ptir/core/error.h"

namespace ptir::eval {

namespace {

Vec3 ramp(float t) {
  // Black -> purple -> red-orange -> yellow -> near white (inferno-like).
  static const Vec3 stops[] = {Vec3(0.0f, 0.0f, 0.02f), Vec3(0.34f, 0.06f, 0.43f), Vec3(0.73f, 0.21f, 0.33f),
                               Vec3(0.98f, 0.55f, 0.04f), Vec3(0.99f, 0.99f, 0.64f)};
  t = std::clamp(t, 0.0f, 1.0f) * 4.0f;
  int i = std::min(3, int(t));
  float f = t - float(i);
  return stops[i] * (1.0f - f) + stops[i + 1] * f;
}

float alpha_at(const Image* alpha, size_t i) {
  if (!alpha) return 1.0f;
  return std::clamp(alpha->pixels[i * alpha->channels + (alpha->channels - 1)], 0.0f, 1.0f);
}

void check(const Image& a, const Image& b, const char* what) {
  if (a.width != b.width || a.height != b.height) throw Error(std::string(what) + ": image sizes differ");
}

}  // namespace

Image heatmap(const Image& error, float full_scale, const Image* show, Vec3 background) {
  if (show) check(error, *show, "heatmap");
  Image out(error.width, error.height, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(error.width) * error.height; i < n; ++i) {
    Vec3 c = (show && show->pixels[i * show->channels] <= 0.5f) ? background
                                                                 : ramp(error.pixels[i * error.channels] / full_scale);
    for (int k = 0; k < 3; ++k) out.pixels[i * 3 + k] = c[k];
  }
  return out;
}

Image abs_difference(const Image& a, const Image& b) {
  check(a, b, "abs_difference");
  if (a.channels < 3 || b.channels < 3) throw Error("abs_difference: needs 3 channels");
  Image out(a.width, a.height, {"Y"});
  for (size_t i = 0, n = size_t(a.width) * a.height; i < n; ++i) {
    float s = 0.0f;
    for (int c = 0; c < 3; ++c) s += std::fabs(a.pixels[i * a.channels + c] - b.pixels[i * b.channels + c]);
    out.pixels[i] = s / 3.0f;
  }
  return out;
}

Image angle_difference(const Image& a, const Image& b) {
  check(a, b, "angle_difference");
  if (a.channels < 3 || b.channels < 3) throw Error("angle_difference: needs 3 channels");
  Image out(a.width, a.height, {"Y"});
  for (size_t i = 0, n = size_t(a.width) * a.height; i < n; ++i) {
    Vec3 u(a.pixels[i * a.channels], a.pixels[i * a.channels + 1], a.pixels[i * a.channels + 2]);
    Vec3 v(b.pixels[i * b.channels], b.pixels[i * b.channels + 1], b.pixels[i * b.channels + 2]);
    float lu = length(u), lv = length(v);
    out.pixels[i] = (lu > 1e-6f && lv > 1e-6f)
                        ? std::acos(std::clamp(dot(u, v) / (lu * lv), -1.0f, 1.0f)) * (180.0f / 3.14159265f)
                        : 0.0f;
  }
  return out;
}

Image grey_to_rgb(const Image& grey, const Image* alpha, Vec3 background) {
  if (alpha) check(grey, *alpha, "grey_to_rgb");
  Image out(grey.width, grey.height, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(grey.width) * grey.height; i < n; ++i) {
    float a = alpha_at(alpha, i), v = std::clamp(grey.pixels[i * grey.channels], 0.0f, 1.0f);
    for (int c = 0; c < 3; ++c) out.pixels[i * 3 + c] = v * a + background[c] * (1.0f - a);
  }
  return out;
}

Image normals_to_rgb(const Image& normal, const Image* alpha, Vec3 background) {
  if (alpha) check(normal, *alpha, "normals_to_rgb");
  if (normal.channels < 3) throw Error("normals_to_rgb: needs 3 channels");
  Image out(normal.width, normal.height, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(normal.width) * normal.height; i < n; ++i) {
    float a = alpha_at(alpha, i);
    for (int c = 0; c < 3; ++c) {
      float v = std::clamp(0.5f + 0.5f * normal.pixels[i * normal.channels + c], 0.0f, 1.0f);
      out.pixels[i * 3 + c] = v * a + background[c] * (1.0f - a);
    }
  }
  return out;
}

Image contact_sheet(const std::vector<std::vector<Image>>& rows, int scale, int gap, Vec3 gap_colour) {
  if (rows.empty() || rows[0].empty()) throw Error("contact_sheet: no tiles");
  scale = std::max(1, scale);
  gap = std::max(0, gap);
  const int tw = rows[0][0].width, th = rows[0][0].height;
  size_t cols = 0;
  for (const auto& r : rows) {
    cols = std::max(cols, r.size());
    for (const Image& t : r)
      if (t.width != tw || t.height != th || t.channels < 3) throw Error("contact_sheet: tiles differ in size or are not RGB");
  }
  const int W = int(cols) * (tw * scale + gap) + gap, H = int(rows.size()) * (th * scale + gap) + gap;
  Image out(W, H, {"R", "G", "B"});
  for (size_t i = 0, n = size_t(W) * H; i < n; ++i)
    for (int c = 0; c < 3; ++c) out.pixels[i * 3 + c] = gap_colour[c];
  for (size_t r = 0; r < rows.size(); ++r)
    for (size_t k = 0; k < rows[r].size(); ++k) {
      const Image& t = rows[r][k];
      const int x0 = gap + int(k) * (tw * scale + gap), y0 = gap + int(r) * (th * scale + gap);
      for (int y = 0; y < th * scale; ++y)
        for (int x = 0; x < tw * scale; ++x)
          for (int c = 0; c < 3; ++c) out.at(x0 + x, y0 + y, c) = t.at(x / scale, y / scale, c);
    }
  return out;
}

}  // namespace ptir::eval
