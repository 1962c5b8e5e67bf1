// The geometry stage's set-up, parameters and iteration (geometry_fit.h);
// densification in geometry_fit_densify.cpp, checkpoints and outputs in
// geometry_fit_io.cpp.
#include "ptir/optim/geometry_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>

#include "ptir/core/error.h"
#include "ptir/math/rng.h"
#include "ptir/optim/geometry_fit_groups.h"
#include "ptir/optim/pseudo_normals.h"
#include "ptir/optim/view_pyramid.h"
#include "ptir/render/splat_composite.h"
#include "ptir/transport/orient_normals.h"

namespace ptir {

namespace {

// 3DGS's camera extent: 1.1 x the largest distance of a camera centre from their mean.
float camera_extent(const Dataset& data) {
  Vec3 mean(0.0f);
  for (const DatasetView& v : data.views) mean += v.camera.centre();
  mean = mean / float(std::max<size_t>(1, data.size()));
  float r = 0.0f;
  for (const DatasetView& v : data.views) r = std::max(r, length(v.camera.centre() - mean));
  return 1.1f * std::max(r, 1e-3f);
}

}  // namespace

GeometryFit::GeometryFit(GaussianField field, std::shared_ptr<const Dataset> dataset, const GeometryFitSettings& s)
    : settings_(s), dataset_(std::move(dataset)), field_(std::move(field)) {
  if (!dataset_ || dataset_->size() == 0) throw Error("geometry fit: the dataset has no training views");
  if (field_.size() == 0) throw Error(field_.source_path, "no Gaussians to fit");
  if (settings_.iterations < 0) throw Error("geometry fit: iterations must be >= 0");
  initial_count_ = field_.size();
  if (settings_.max_gaussians == 0) settings_.max_gaussians = initial_count_ + initial_count_ / 2;
  extent_ = camera_extent(*dataset_);
  // Normals not from the file: the shortest axis (the loader's), faced toward the cameras.
  if (!field_.normals_from_file) {
    SceneAccel accel(field_, {}, settings_.accel);
    orient_normals_to_cameras(field_, accel, dataset_->cameras());
  }
  // The output is the standard layout of the current values, not the input's rows.
  field_.source = io::PlyFile();
  groups_ = make_fit_groups(field_, settings_, extent_);
  for (const ParameterGroup& g : groups_) adam_.emplace_back(g.raw.size(), g.lr);
  grad_accum_.assign(field_.size(), 0.0f);
  grad_count_.assign(field_.size(), 0.0f);
  apply();
}

void GeometryFit::apply() { apply_fit_groups(groups_, field_); }

size_t GeometryFit::view_of(int it) const {
  const size_t n = dataset_->size();
  const uint64_t epoch = uint64_t(it) / n;
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t(0));
  std::mt19937_64 rng(hash_combine(settings_.seed, epoch));
  for (size_t i = n; i > 1; --i) std::swap(order[i - 1], order[size_t(rng() % i)]);
  return order[size_t(it) % n];
}

int GeometryFit::coarse_factor() const {
  return pyramid_factor(dataset_->width, dataset_->height, settings_.coarse_pixels);
}

int GeometryFit::level_factor(int it) const {
  return double(it) < coarse_share() * double(settings_.iterations) ? coarse_factor() : 1;
}

std::shared_ptr<const TrainingImage> GeometryFit::target_at(size_t view, int f) const {
  if (f == 1) return dataset_->target(view);
  if (reduced_factor_ != f || reduced_.size() != dataset_->size()) {
    reduced_.assign(dataset_->size(), nullptr);
    reduced_factor_ = f;
  }
  if (!reduced_[view]) reduced_[view] = std::make_shared<const TrainingImage>(reduce_training_image(*dataset_->target(view), f));
  return reduced_[view];
}

namespace {

// alpha * srgb(rgb): the target composited on black in display space.
Image display_target(const TrainingImage& t) {
  Image out(t.rgb.width, t.rgb.height, {"R", "G", "B"});
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const float a = t.alpha.at(x, y, 0);
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = a * linear_to_srgb(std::max(0.0f, t.rgb.at(x, y, c)));
    }
  return out;
}

// mean |O - alpha| and its gradient times `weight`.
double mask_term(const Image& opacity, const Image& alpha, float weight, Image* d_opacity) {
  *d_opacity = Image(opacity.width, opacity.height, {"A"});
  const size_t n = opacity.pixels.size();
  double sum = 0;
  for (size_t i = 0; i < n; ++i) {
    const float d = opacity.pixels[i] - alpha.pixels[i];
    sum += std::fabs(d);
    d_opacity->pixels[i] = d > 0 ? weight / float(n) : (d < 0 ? -weight / float(n) : 0.0f);
  }
  return sum / double(std::max<size_t>(1, n));
}

}  // namespace

Image GeometryFit::normal_target(const Camera& cam, const SplatImage& fwd) const {
  const Image& depth = settings_.median_depth ? fwd.median_depth : fwd.depth;
  return pseudo_normals(cam, depth, fwd.opacity, settings_.normal_radius);
}

FitLog GeometryFit::step(const std::atomic<bool>* cancel) {
  const auto t0 = std::chrono::steady_clock::now();
  const int it = iteration_;
  FitLog log;
  log.iteration = it + 1;
  log.view = view_of(it);
  log.level = level_factor(it);
  const Camera cam = reduce_camera(dataset_->views[log.view].camera, log.level);
  const auto target = target_at(log.view, log.level);
  RenderControl control;
  control.cancel = cancel;

  using clock = std::chrono::steady_clock;
  auto since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  const auto tb = clock::now();
  SceneAccel accel(field_, {}, settings_.accel);
  log.build_s = since(tb);
  const auto t1 = clock::now();
  const Vec3 black(0.0f);
  SplatImage fwd = render_splat(accel, cam, black, control);
  Image d_colour, d_opacity, d_normal;
  log.image = image_loss(fwd.colour, display_target(*target), nullptr, settings_.loss, &d_colour);
  const bool masked = target->has_alpha && settings_.lambda_mask > 0.0f;
  if (masked) log.mask = mask_term(fwd.opacity, target->alpha, settings_.lambda_mask, &d_opacity);
  const bool normals = it >= settings_.normal_from && settings_.lambda_normal > 0.0f;
  if (normals)
    log.normal = normal_consistency(fwd.normal, normal_target(cam, fwd), settings_.lambda_normal,
                                    &d_normal, settings_.normal_per_hit,
                                    settings_.normal_outlier_deg > 0.0f
                                        ? std::cos(settings_.normal_outlier_deg * 3.14159265f / 180.0f)
                                        : 2.0f);
  log.loss = log.image + settings_.lambda_mask * log.mask + settings_.lambda_normal * log.normal;
  Image d_distortion;
  const bool distortion = it >= settings_.distortion_from && settings_.lambda_distortion > 0.0f;
  if (distortion) {
    // Depths in units of the cameras' extent: the weight does not depend on the scene's scale.
    const size_t n = fwd.distortion.pixels.size();
    double sum = 0;
    for (float v : fwd.distortion.pixels) sum += v;
    log.distortion = sum / (double(std::max<size_t>(1, n)) * extent_);
    log.loss += settings_.lambda_distortion * log.distortion;
    d_distortion = Image(cam.width, cam.height, {"Y"});
    for (float& v : d_distortion.pixels) v = settings_.lambda_distortion / (float(n) * extent_);
  }

  log.forward_s = since(t1);
  const auto t2 = clock::now();
  SplatGradients g;
  g.resize(field_.size(), field_.sh_stride());
  render_splat_backward(accel, cam, black, fwd, &d_colour, masked ? &d_opacity : nullptr, normals ? &d_normal : nullptr,
                        g, control, settings_.normal_to_weights, distortion ? &d_distortion : nullptr);

  // Densification statistics: |dL/dmu| in 3DGS's NDC units (dL/dpixel * W/2).
  const float ndc = std::tan(0.5f * cam.fov_x);
  for (size_t i = 0; i < field_.size(); ++i) {
    const float gl = length(g.position[i]);
    if (!(gl > 0.0f) || !std::isfinite(gl)) continue;
    grad_accum_[i] += gl * length(field_.position[i] - cam.centre()) * ndc;
    grad_count_[i] += 1.0f;
  }
  const std::vector<std::vector<float>> raw = fit_raw_gradients(groups_, g, field_);
  for (size_t k = 0; k < groups_.size(); ++k) adam_[k].step(groups_[k].raw, raw[k]);
  log.backward_s = since(t2);
  iteration_++;
  if (iteration_ % settings_.densify_every == 0 && iteration_ >= settings_.densify_from &&
      iteration_ < settings_.densify_until)
    densify(iteration_, log);
  apply();
  if (settings_.reorient_every > 0 && iteration_ % settings_.reorient_every == 0) reorient_normals(log);
  log.gaussians = field_.size();
  log.seconds = since(t0);
  log_.push_back(log);
  return log;
}

std::vector<size_t> reorient_fit_normals(GaussianField& f, const std::vector<Camera>& cameras,
                                         const AccelSettings& settings) {
  const std::vector<Vec3> before = f.normal;
  const bool from_file = f.normals_from_file;
  f.normals_from_file = false;  // the learnt normals are re-voted whatever their origin
  SceneAccel accel(f, {}, settings);
  orient_normals_to_cameras(f, accel, cameras, 256 * 256, /*keep_unseen=*/true);
  f.normals_from_file = from_file;
  std::vector<size_t> flipped;
  for (size_t i = 0; i < f.size(); ++i)
    if (dot(before[i], f.normal[i]) < 0.0f) flipped.push_back(i);
  return flipped;
}

void GeometryFit::reorient_normals(FitLog& log) {
  const std::vector<size_t> flipped = reorient_fit_normals(field_, dataset_->cameras(), settings_.accel);
  std::vector<float>& raw = groups_[kFitNormal].raw;
  Adam& adam = adam_[kFitNormal];
  for (size_t i : flipped) {
    log.flipped++;
    for (int c = 0; c < 3; ++c) raw[3 * i + c] = -raw[3 * i + c], adam.m[3 * i + c] = -adam.m[3 * i + c];
  }
}

}  // namespace ptir
