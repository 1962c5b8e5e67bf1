#include "ptir/lights/environment.h"

#include <algorithm>
#include <cmath>

#include "ptir/core/error.h"

namespace ptir {

namespace {
constexpr double kPiD = 3.14159265358979323846;
}  // namespace

Environment::Environment() : texels_(3, 0.0f) { rebuild_sampling(); }

Environment::Environment(const Image& image, float strength, float rotation_z, const std::string& name)
    : width_(image.width), height_(image.height), strength_(strength) {
  if (image.width <= 0 || image.height <= 0) throw Error(name, "environment map is empty");
  if (image.channels != 1 && image.channels < 3)
    throw Error(name, "environment map needs 1 (grey) or at least 3 (RGB) channels, got " +
                          std::to_string(image.channels));
  if (image.pixels.size() < size_t(image.width) * image.height * image.channels)
    throw Error(name, "environment map has fewer pixels than width x height x channels");
  texels_.resize(size_t(width_) * height_ * 3);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      for (int c = 0; c < 3; ++c) {
        float v = image.at(x, y, image.channels == 1 ? 0 : c);
        if (!std::isfinite(v))
          throw Error(name, "environment map has a non-finite value at pixel (" + std::to_string(x) + ", " +
                                std::to_string(y) + ")");
        texels_[(size_t(y) * width_ + x) * 3 + c] = std::max(v, 0.0f);
      }
    }
  }
  set_rotation_z(rotation_z);
  rebuild_sampling();
}

Environment Environment::constant(Vec3 radiance, int width, int height) {
  Image img(std::max(width, 1), std::max(height, 1), {"R", "G", "B"});
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = radiance[c];
  return Environment(img, 1.0f, 0.0f, "constant environment");
}

Environment Environment::load(const std::string& path, float strength, float rotation_z) {
  Image img = read_image(path, Encoding::Colour);  // throws Error naming the file
  return Environment(img, strength, rotation_z, path);
}

Vec3 Environment::texel(int x, int y) const {
  const float* p = &texels_[(size_t(y) * width_ + x) * 3];
  return {p[0], p[1], p[2]};
}

void Environment::set_texel(int x, int y, Vec3 rgb) {
  float* p = &texels_[(size_t(y) * width_ + x) * 3];
  p[0] = rgb.x;
  p[1] = rgb.y;
  p[2] = rgb.z;
}

void Environment::set_rotation_z(float r) {
  rotation_z_ = r;
  cos_rot_ = std::cos(r);
  sin_rot_ = std::sin(r);
}

void Environment::rebuild_sampling() {
  std::vector<float> weights(size_t(width_) * height_);
  for (int y = 0; y < height_; ++y) {
    const float sin_theta = float(std::sin(kPiD * (y + 0.5) / height_));
    for (int x = 0; x < width_; ++x) weights[size_t(y) * width_ + x] = luminance(texel(x, y)) * sin_theta;
  }
  distribution_ = Distribution2D(weights.data(), width_, height_);
}

Vec3 Environment::to_world(Vec3 d) const {
  return {cos_rot_ * d.x + sin_rot_ * d.y, -sin_rot_ * d.x + cos_rot_ * d.y, d.z};
}

// u in [0, 1), t = theta / pi = 1 - v in [0, 1], and sin(theta), of the lookup
// direction Rz(rotation) d, in double precision. theta = atan2(|xy|, z) stays
// accurate near the poles, where acos(z) of a float z would not.
void Environment::local_angles(Vec3 d, double* u, double* t, double* sin_theta) const {
  const double x = double(cos_rot_) * d.x - double(sin_rot_) * d.y;
  const double y = double(sin_rot_) * d.x + double(cos_rot_) * d.y;
  const double z = d.z;
  const double rxy = std::hypot(x, y);
  double uu = 0.5 - std::atan2(y, x) / (2.0 * kPiD);
  if (uu >= 1.0) uu -= 1.0;
  if (uu < 0.0) uu += 1.0;
  *u = uu;
  *t = std::atan2(rxy, z) / kPiD;
  if (sin_theta) {
    const double len = std::sqrt(rxy * rxy + z * z);
    *sin_theta = len > 0.0 ? rxy / len : 0.0;
  }
}

EnvUV Environment::direction_to_uv(Vec3 d) const {
  double u, t;
  local_angles(d, &u, &t, nullptr);
  return {float(u), float(1.0 - t)};
}

Vec3 Environment::uv_to_direction(float u, float v) const {
  const double phi = kPiD * (1.0 - 2.0 * double(u));
  const double theta = kPiD * (1.0 - double(v));
  const double st = std::sin(theta);
  Vec3 l(float(st * std::cos(phi)), float(st * std::sin(phi)), float(std::cos(theta)));
  return to_world(l);
}

void Environment::cell_of(double u, double t, int* x, int* y) const {
  int ix = int(std::floor(u * width_));
  *x = ((ix % width_) + width_) % width_;
  *y = std::clamp(int(std::floor(t * height_)), 0, height_ - 1);
}

float Environment::pdf_at(int x, int y, double sin_theta) const {
  if (!(sin_theta > 0.0)) return 0.0f;
  return float(double(distribution_.pdf_cell(x, y)) / (2.0 * kPiD * kPiD * sin_theta));
}

void Environment::texel_coords(Vec3 d, int* x, int* y) const {
  double u, t;
  local_angles(d, &u, &t, nullptr);
  cell_of(u, t, x, y);
}

int Environment::texel_index(Vec3 d) const {
  int x, y;
  texel_coords(d, &x, &y);
  return y * width_ + x;
}

Vec3 Environment::eval(Vec3 d) const {
  int x, y;
  texel_coords(d, &x, &y);
  return texel(x, y) * strength_;
}

EnvSample Environment::sample(float u0, float u1) const {
  EnvSample s;
  Sample2D uv = distribution_.sample(u0, u1);  // uv.x = u, uv.y = t = 1 - v
  const double theta = kPiD * double(uv.y);
  const double sin_theta = std::sin(theta);
  if (!(sin_theta > 0.0) || !(uv.pdf > 0.0f)) return s;
  const double phi = kPiD * (1.0 - 2.0 * double(uv.x));
  Vec3 l(float(sin_theta * std::cos(phi)), float(sin_theta * std::sin(phi)), float(std::cos(theta)));
  s.wi = to_world(l);
  s.texel = uv.iy * width_ + uv.ix;
  s.Li = texel(uv.ix, uv.iy) * strength_;
  s.pdf = float(double(uv.pdf) / (2.0 * kPiD * kPiD * sin_theta));
  return s;
}

float Environment::pdf(Vec3 d) const {
  double u, t, sin_theta;
  local_angles(d, &u, &t, &sin_theta);
  int ix, iy;
  cell_of(u, t, &ix, &iy);
  return pdf_at(ix, iy, sin_theta);
}

Vec3 Environment::eval_pdf(Vec3 d, float* pdf) const {
  double u, t, sin_theta;
  local_angles(d, &u, &t, &sin_theta);
  int ix, iy;
  cell_of(u, t, &ix, &iy);
  *pdf = pdf_at(ix, iy, sin_theta);
  return texel(ix, iy) * strength_;
}

// ---- EnvironmentLight

std::string Environment::describe() const {
  return "latlong " + std::to_string(width_) + "x" + std::to_string(height_);
}

EnvLightSample Environment::sample_li(float u0, float u1, float /*u2*/) const {
  EnvSample s = sample(u0, u1);
  return {s.wi, s.Li, s.pdf};
}

void Environment::adjoint(Vec3 d, Vec3 d_Le, float* grad) const {
  // Le = strength * texel(d) (nearest lookup): one texel receives it all.
  int t = texel_index(d);
  if (t < 0) return;
  Vec3 g = d_Le * strength_;
  float* p = grad + 3 * size_t(t);
  p[0] += g.x;
  p[1] += g.y;
  p[2] += g.z;
}

void Environment::get_raw(float* raw) const {
  for (size_t i = 0; i < texels_.size(); ++i) raw[i] = std::log(std::max(texels_[i], 1e-8f));
}

void Environment::set_raw(const float* raw) {
  for (size_t i = 0; i < texels_.size(); ++i) texels_[i] = std::exp(raw[i]);
  rebuild_sampling();
}

void Environment::raw_gradient(const float* raw, const float* d_value, float* d_raw) const {
  for (size_t i = 0; i < texels_.size(); ++i) d_raw[i] = d_value[i] * std::exp(raw[i]);
}

Image Environment::to_latlong(int /*w*/, int /*h*/) const {
  if (rotation_z_ != 0.0f) return rasterise_latlong(*this, width_, height_);
  Image img(width_, height_, {"R", "G", "B"});
  img.pixels = texels_;
  if (strength_ != 1.0f)
    for (float& v : img.pixels) v *= strength_;
  return img;
}

}  // namespace ptir
