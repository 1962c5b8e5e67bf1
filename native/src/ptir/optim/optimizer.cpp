#include "ptir/optim/optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "ptir/core/error.h"
#include "ptir/math/rng.h"
#include "ptir/optim/data_parallel.h"
#include "ptir/optim/light_balance.h"
#include "ptir/optim/loss_space.h"
#include "ptir/optim/patch_batch.h"
#include "ptir/optim/view_pyramid.h"
#include "ptir/render/aov.h"
#include "ptir/render/aov_backward.h"
#include "ptir/render/material_maps.h"
#include "ptir/render/render_path.h"
#include "ptir/render/row_bands.h"
#include "ptir/transport/orient_normals.h"

namespace ptir {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// CPU seconds used by the whole process (every thread) so far.
double process_cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Stream tags for the keyed random numbers of the loop.
constexpr uint64_t kTagViews = 0x7669657773ull;  // "views"
constexpr uint64_t kTagCrop = 0x63726f70ull;     // "crop"
constexpr uint64_t kTagPath = 0x70617468ull;     // "path"
constexpr uint64_t kTagHalfA = 0x68616c6661ull;  // "halfa"
constexpr uint64_t kTagHalfB = 0x68616c6662ull;  // "halfb"

Image crop_image(const Image& img, int x0, int y0, int w, int h) {
  if (x0 == 0 && y0 == 0 && w == img.width && h == img.height) return img;
  Image out(w, h, img.channel_names);
  for (int y = 0; y < h; ++y)
    std::memcpy(&out.pixels[size_t(y) * w * img.channels], &img.pixels[(size_t(y + y0) * img.width + x0) * img.channels],
                sizeof(float) * size_t(w) * img.channels);
  return out;
}

bool all_zero(const Image& img) {
  for (float v : img.pixels)
    if (v != 0.0f) return false;
  return true;
}

}  // namespace

Optimizer::Optimizer(Scene scene, std::shared_ptr<const Dataset> dataset, const OptimizerSettings& settings)
    : settings_(settings), scene_(std::make_unique<Scene>(std::move(scene))), dataset_(std::move(dataset)) {
  if (!dataset_ || dataset_->size() == 0) throw Error("the optimiser needs a dataset with at least one view");
  if (!scene_->gaussians) scene_->gaussians = std::make_shared<GaussianField>();
  if (scene_->gaussians->size() == 0 && scene_->meshes.empty()) throw Error("nothing to optimise: the scene has no Gaussians");
  if (settings_.iterations < 0) throw Error("iterations must be >= 0");
  if (settings_.integrator.spp < 1) throw Error("spp must be at least 1");
  if (settings_.integrator.max_bounces < 0) throw Error("bounces must be at least 0");
  // Automatic batch (views 0, crop -1): patches across the views (patch_batch.h).
  if (settings_.views_per_iteration < 0) throw Error("views per iteration must be at least 1 (0: automatic)");
  if (settings_.crop_size < -1) throw Error("crop size must be >= 0 (-1: automatic)");
  if (settings_.coarse_pixels < 0) throw Error("coarse pixels must be >= 0 (0: no resolution pyramid)");
  if (settings_.coarse_spp < 0) throw Error("coarse spp must be >= 0 (0: the spp)");
  if (!(settings_.fine_fraction >= 0.0f && settings_.fine_fraction <= 1.0f)) throw Error("the fine fraction must be in [0, 1]");
  auto_batch_ = settings_.views_per_iteration == 0 || settings_.crop_size < 0;
  auto_views_ = settings_.views_per_iteration == 0;
  resolve_patch_batch(dataset_->width, dataset_->height, int(dataset_->size()), &settings_.views_per_iteration,
                      &settings_.crop_size);
  if (!(settings_.lr_final > 0.0f && settings_.lr_final <= 1.0f)) throw Error("the final learning-rate factor must be in (0, 1]");
  if (!(settings_.lr_decay_start >= 0.0f && settings_.lr_decay_start < 1.0f))
    throw Error("the learning-rate decay start must be in [0, 1)");
  GaussianField& field = *scene_->gaussians;
  const size_t n = field.size();
  if (field.normal.size() != n) init_normals_shortest_axis(field);
  field.albedo.resize(n);
  field.roughness.resize(n);
  field.metallic.resize(n);

  install_environment(*scene_, settings_.params);
  params_ = make_parameters(*scene_, settings_.params);
  if (settings_.params.learn_exposure)  // per-view exposure (exposure.h)
    params_.groups.push_back({ParamKind::Exposure, settings_.params.lr_exposure, std::vector<float>(dataset_->size(), 0.0f)});
  if (settings_.light_balance && light_balance_applies(params_, *scene_))  // light_balance.h
    params_.groups.push_back({ParamKind::LightBalance, settings_.params.lr_balance, std::vector<float>(3, 0.0f)});
  for (const ParameterGroup& g : params_.groups) adam_.emplace_back(g.raw.size(), g.lr, settings_.adam);
  apply();
  tracer_ = std::make_unique<PathTracer>(*scene_, settings_.accel);
  if (settings_.orient_normals && !field.normals_from_file && n > 0) {
    std::vector<Camera> cams = dataset_->cameras();
    int rays_per_camera = std::max(4096, int(262144 / std::max<size_t>(1, cams.size())));
    orient_normals_to_cameras(field, tracer_->accel(), cams, rays_per_camera);
  }
  if (settings_.env_align.mode != EnvAlignMode::Off) {  // the known map lined up with the photos (env_align.h)
    env_align_ = align_environment(*scene_, *tracer_, *dataset_, settings_.integrator, settings_.env_align);
    if (ParameterGroup* g = params_.find(ParamKind::Environment)) scene_->environment->get_raw(g->raw.data());
  }
  grads_ = SceneGradients::zeros_like(*scene_);
  mask_box_.assign(dataset_->size(), {0, 0, -1, -1});
  if (env_align_.scale_from == "short inversions") search_known_level();  // optimizer_known_level.cpp
}

Optimizer::~Optimizer() = default;

void Optimizer::apply() { apply_parameters(params_, settings_.params, *scene_); }

double Optimizer::prior_weight(int it) const {
  if (settings_.prior_iterations <= 0) return settings_.prior_end;
  double f = std::min(1.0, double(it) / double(settings_.prior_iterations));
  return settings_.prior_start + (settings_.prior_end - settings_.prior_start) * f;
}

double Optimizer::lr_factor(int it) const {
  const double n = double(settings_.iterations), start = settings_.lr_decay_start * n;
  if (settings_.lr_final == 1.0f || n <= 0.0 || double(it) <= start) return 1.0;
  const double f = std::min(1.0, (double(it) - start) / std::max(1.0, n - 1.0 - start));
  return std::pow(double(settings_.lr_final), f);
}

double Optimizer::warmup_factor(float fraction, int it) const {
  const double warm = double(fraction) * double(settings_.iterations);
  return warm <= 0.0 ? 1.0 : std::min(1.0, (double(it) + 1.0) / warm);
}

double Optimizer::albedo_lr_factor(int it) const { return warmup_factor(settings_.albedo_warmup, it); }

double Optimizer::tv_weight(int it) const {
  const double half = 0.5 * double(settings_.iterations);
  const double f = half <= 0.0 ? 0.0 : std::max(0.0, 1.0 - double(it) / half);
  return double(settings_.lambda_tv) * (1.0 + (double(settings_.tv_warmup) - 1.0) * f);
}

const std::array<int, 4>& Optimizer::mask_box(size_t view) const {
  std::array<int, 4>& b = mask_box_[view];
  if (b[2] >= b[0]) return b;
  auto t = dataset_->target(view);
  const int W = t->alpha.width, H = t->alpha.height;
  int x0 = W, y0 = H, x1 = -1, y1 = -1;
  if (t->has_alpha) {
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (t->alpha.pixels[size_t(y) * W + x] > 0.5f) {
          x0 = std::min(x0, x);
          x1 = std::max(x1, x);
          y0 = std::min(y0, y);
          y1 = std::max(y1, y);
        }
  }
  if (x1 < 0) b = {0, 0, W - 1, H - 1};  // no alpha (or an empty mask): the whole image
  else b = {x0, y0, x1, y1};
  return b;
}

int Optimizer::pyramid_coarse_factor() const {
  return pyramid_factor(dataset_->width, dataset_->height, settings_.coarse_pixels);
}

int Optimizer::pyramid_level_factor(int it) const {
  if (double(it) >= pyramid_coarse_share() * double(settings_.iterations)) return 1;
  return pyramid_coarse_factor();
}

std::pair<int, int> Optimizer::batch_at(int f) const {
  if (f == 1 || !auto_batch_) return {settings_.views_per_iteration, settings_.crop_size};
  const PatchBatch b = default_patch_batch(dataset_->width / f, dataset_->height / f, int(dataset_->size()));
  return {b.views, b.side};
}

std::array<int, 4> Optimizer::mask_box(size_t view, int f) const {
  const auto& b = mask_box(view);
  if (f == 1) return b;
  const int W = dataset_->width / f - 1, H = dataset_->height / f - 1;
  return {std::min(b[0] / f, W), std::min(b[1] / f, H), std::min(b[2] / f, W), std::min(b[3] / f, H)};
}

std::shared_ptr<const TrainingImage> Optimizer::reduced_target(size_t view, int f) const {
  if (f == 1) return dataset_->target(view);
  if (reduced_factor_ != f) {
    reduced_.assign(dataset_->size(), nullptr);
    reduced_factor_ = f;
  }
  if (reduced_.size() != dataset_->size()) reduced_.assign(dataset_->size(), nullptr);
  if (!reduced_[view]) reduced_[view] = std::make_shared<const TrainingImage>(reduce_training_image(*dataset_->target(view), f));
  return reduced_[view];
}

std::vector<Optimizer::ViewPick> Optimizer::pick_views(int it) const {
  const size_t N = dataset_->size();
  const int f = pyramid_level_factor(it);
  const auto [k, cs] = batch_at(f);
  const int W = dataset_->width / f, H = dataset_->height / f;
  std::vector<ViewPick> picks;
  for (int v = 0; v < k; ++v) {
    const uint64_t slot = uint64_t(it) * uint64_t(k) + uint64_t(v);
    const uint64_t epoch = slot / N, pos = slot % N;
    // Fisher-Yates permutation of the views for this epoch (keyed: any iteration can be recomputed).
    std::vector<size_t> perm(N);
    for (size_t i = 0; i < N; ++i) perm[i] = i;
    Rng rng(settings_.seed, kTagViews, epoch);
    for (size_t i = N; i > 1; --i) {
      size_t j = std::min(i - 1, size_t(rng.at(i) * float(i)));
      std::swap(perm[i - 1], perm[j]);
    }
    ViewPick p{perm[pos], 0, 0, W, H, f};
    if (cs > 0 && (cs < W || cs < H)) {
      p.w = std::min(cs, W);
      p.h = std::min(cs, H);
      Rng r(hash_combine(settings_.seed, kTagCrop), uint64_t(it), uint64_t(v));
      // With the background supervised, a share of the patches goes anywhere in the view.
      const bool anywhere = settings_.background_loss && r.at(2) >= settings_.object_patch_share;
      const std::array<int, 4> b = anywhere ? std::array<int, 4>{0, 0, W - 1, H - 1} : mask_box(p.view, f);
      int cx = b[0] + std::min(b[2] - b[0], int(r.at(0) * float(b[2] - b[0] + 1)));
      int cy = b[1] + std::min(b[3] - b[1], int(r.at(1) * float(b[3] - b[1] + 1)));
      p.x0 = std::clamp(cx - p.w / 2, 0, W - p.w);
      p.y0 = std::clamp(cy - p.h / 2, 0, H - p.h);
    }
    picks.push_back(p);
  }
  return picks;
}

void Optimizer::set_parameters(const Parameters& p) {
  if (p.groups.size() != params_.groups.size()) throw Error("set_parameters: different parameter groups");
  for (size_t i = 0; i < p.groups.size(); ++i)
    if (p.groups[i].kind != params_.groups[i].kind || p.groups[i].raw.size() != params_.groups[i].raw.size())
      throw Error(std::string("set_parameters: group '") + param_kind_name(p.groups[i].kind) + "' does not match");
  params_ = p;
  apply();
}

IterationLog Optimizer::step(const std::atomic<bool>* cancel) {
  const auto t_start = Clock::now();
  const double cpu_start = process_cpu_seconds();
  IterationLog log = evaluate(iteration_, true, cancel);

  // Adam on the raw parameters (only now does the state change).
  auto t0 = Clock::now();
  std::vector<std::vector<float>> raw = raw_gradients(params_, grads_, *scene_);
  for (auto& g : raw)
    for (float& d : g)
      if (!std::isfinite(d)) {
        d = 0.0f;
        ++nonfinite_;
      }
  const double lr_scale = lr_factor(iteration_);
  std::array<float, 3> balance_step = {0.0f, 0.0f, 0.0f};
  for (size_t i = 0; i < params_.groups.size(); ++i) {
    if (params_.groups[i].kind == ParamKind::Exposure) raw[i] = exposure_grads_.raw_gradient();  // exposure.h
    if (params_.groups[i].kind == ParamKind::LightBalance)
      for (int c = 0; c < 3; ++c) raw[i][c] = float(balance_grad_[c]);
    const ParamKind kind = params_.groups[i].kind;
    const bool albedo = kind == ParamKind::GaussianAlbedo || kind == ParamKind::MeshColour;
    if (kind == ParamKind::LightBalance && double(iteration_) < double(settings_.balance_start) * settings_.iterations) continue;
    adam_[i].lr = float(params_.groups[i].lr * lr_scale * (albedo ? albedo_lr_factor(iteration_) : 1.0));
    const std::vector<float> before = kind == ParamKind::LightBalance ? params_.groups[i].raw : std::vector<float>();
    adam_[i].step(params_.groups[i].raw, raw[i]);
    if (params_.groups[i].kind == ParamKind::Exposure) centre_exposure(params_.groups[i]);
    if (kind == ParamKind::LightBalance) balance_step = {params_.groups[i].raw[0] - before[0], params_.groups[i].raw[1] - before[1],
                                                         params_.groups[i].raw[2] - before[2]};
  }
  // The balance's step moves the albedos against the light (after their own steps).
  if (balance_step != std::array<float, 3>{0.0f, 0.0f, 0.0f}) light_balance_shift(params_, balance_step);
  if (settings_.neutral_light) light_balance_shift(params_, neutral_light_delta(params_));
  apply();
  log.update_s = seconds_since(t0);
  log.seconds = seconds_since(t_start);
  log.cpu_s = process_cpu_seconds() - cpu_start;
  ++iteration_;
  log_.push_back(log);
  return log;
}

// One view of an iteration: its camera (cropped), targets and path seed.
struct Optimizer::ViewWork {
  const DatasetView* view = nullptr;
  ViewPick pick;
  Camera cam;
  std::shared_ptr<const TrainingImage> full;
  Image target_rgb, target_alpha;  // cropped, linear
  Image target;                    // cropped, in loss space (also the TV guide)
  size_t px = 0;
  IntegratorSettings is;
};

Optimizer::ViewWork Optimizer::view_work(int it, size_t v, const ViewPick& pk) const {
  ViewWork w;
  w.pick = pk;
  w.view = &dataset_->views[pk.view];
  w.cam = reduce_camera(w.view->camera, pk.factor);
  if (pk.w != w.cam.width || pk.h != w.cam.height) w.cam = w.cam.crop(pk.x0, pk.y0, pk.w, pk.h);
  w.full = reduced_target(pk.view, pk.factor);
  w.target_rgb = crop_image(w.full->rgb, pk.x0, pk.y0, pk.w, pk.h);
  w.target_alpha = crop_image(w.full->alpha, pk.x0, pk.y0, pk.w, pk.h);
  w.px = size_t(pk.w) * pk.h;
  w.target = Image(pk.w, pk.h, {"R", "G", "B"});
  for (size_t p = 0; p < 3 * w.px; ++p) w.target.pixels[p] = loss_encode(w.target_rgb.pixels[p]);
  w.is = settings_.integrator;
  w.is.spp = spp_at(pk.factor);
  w.is.seed = hash_combine(hash_combine(settings_.seed, kTagPath), hash_combine(uint64_t(it), uint64_t(v)));
  return w;
}

float Optimizer::loss_encode(float c) const { return settings_.srgb_loss ? srgb_encode_unclamped(c) : c; }
float Optimizer::loss_encode_derivative(float c) const { return settings_.srgb_loss ? srgb_encode_derivative(c) : 1.0f; }

// One primal render of a view at `is` and what its replay needs (each sample's
// radiance, ray outcomes and walks per row band, data_parallel.h, when they fit).
struct Optimizer::Primal {
  IntegratorSettings is;
  Image render;  // RGB exposed by the view's scale, A = coverage
  bool cache = false;
  std::vector<ReplayCache> bands;  // per band; walks in Optimizer::walk_stores_
};

Optimizer::Primal Optimizer::primal(const ViewWork& w, const IntegratorSettings& is, bool with_gradients,
                                    size_t cache_bytes, int part, const RenderControl& control,
                                    IterationLog& log) const {
  auto t0 = Clock::now();
  double c0 = process_cpu_seconds();
  Primal r;
  r.is = is;
  const size_t sample_bytes = w.px * size_t(is.spp) * (sizeof(Vec3) + sizeof(uint64_t));
  r.cache = with_gradients && sample_bytes <= cache_bytes;
  if (r.cache) {  // the rest of the budget keeps walks, shared by the bands
    auto& stores = walk_stores_[size_t(part)];
    const size_t bands = rank_row_bands(w.cam.height, *comm_).size();
    while (stores.size() < bands) stores.push_back(std::make_unique<WalkStore>(0));
    r.bands.resize(bands);
    for (size_t b = 0; b < bands; ++b) {
      stores[b]->set_budget((cache_bytes - sample_bytes) / bands);
      r.bands[b].walks = stores[b].get();
    }
  }
  r.render = render_path_ranks(*comm_, *tracer_, w.cam, is, control, r.cache ? &r.bands : nullptr);
  ExposureGradients::expose(r.render, ExposureGradients::scale(params_, w.pick.view));  // the loss sees s_v x render
  log.primal_s += seconds_since(t0);
  log.primal_cpu_s += process_cpu_seconds() - c0;
  return r;
}

void Optimizer::image_term(const ViewWork& w, float inv_k, bool with_gradients, const RenderControl& control,
                           IterationLog& log) {
  const ViewPick& pk = w.pick;
  // The primal render(s). Decorrelated (decorrelate_adjoint, optimizer.h): two
  // independent halves of the samples; each half's replay is weighted by the
  // loss gradient of the *other* half's image.
  std::vector<Primal> parts;
  if (with_gradients && settings_.decorrelate_adjoint && w.is.spp >= 2) {
    IntegratorSettings a = w.is, b = w.is;
    a.spp = w.is.spp / 2;
    b.spp = w.is.spp - a.spp;
    a.seed = hash_combine(w.is.seed, kTagHalfA);
    b.seed = hash_combine(w.is.seed, kTagHalfB);
    parts.push_back(primal(w, a, true, settings_.sample_cache_bytes / 2, 0, control, log));
    parts.push_back(primal(w, b, true, settings_.sample_cache_bytes / 2, 1, control, log));
  } else {
    parts.push_back(primal(w, w.is, with_gradients, settings_.sample_cache_bytes, 0, control, log));
  }
  // The whole render (the halves' sample-weighted mean): the mask and the logged loss.
  Image render = parts[0].render;
  if (parts.size() == 2) {
    const float wa = float(parts[0].is.spp) / float(w.is.spp), wb = 1.0f - wa;
    for (size_t i = 0; i < render.pixels.size(); ++i)
      render.pixels[i] = wa * parts[0].render.pixels[i] + wb * parts[1].render.pixels[i];
  }
  Image mask(pk.w, pk.h, {"A"});
  size_t masked = 0;
  const bool masked_loss = w.full->has_alpha && !settings_.background_loss;
  for (size_t p = 0; p < w.px; ++p) {
    bool in = !masked_loss || (w.target_alpha.pixels[p] >= settings_.mask_threshold &&
                                     render.pixels[p * 4 + 3] >= settings_.mask_threshold);
    mask.pixels[p] = in ? 1.0f : 0.0f;
    masked += in;
  }
  if (masked == 0) return;
  // The loss space (loss_space.h): the target outside the mask, the sRGB curve after the blur by default.
  const LossCurve curve = !settings_.srgb_loss        ? LossCurve::Linear
                          : settings_.srgb_after_blur ? LossCurve::SrgbBlurFirst
                                                      : LossCurve::Srgb;
  const LossSpace space(curve, settings_.loss, w.target_rgb, mask);
  const Image& target = space.target();
  const ImageLossSettings& loss_settings = space.loss();
  auto loss_space = [&](const Image& r) { return space.encode(r); };
  auto through_curve = [&](const Image& d_pred, const Image& r) { return space.adjoint(d_pred, r); };
  const Image* mask_ptr = masked_loss ? &mask : nullptr;
  // dL/d(linear render) of one image: through the loss and the loss-space curve.
  auto adjoint = [&](const Image& r, double* loss) {
    Image d_pred;
    const double l = image_loss(loss_space(r), target, mask_ptr, loss_settings, &d_pred);
    if (loss) *loss = l;
    return through_curve(d_pred, r);
  };
  if (!with_gradients) {
    log.image += inv_k * image_loss(loss_space(render), target, mask_ptr, loss_settings, nullptr);
    return;
  }
  std::vector<Image> d_renders;
  if (parts.size() == 1) {
    double l = 0.0;
    d_renders.push_back(adjoint(render, &l));
    log.image += inv_k * l;
  } else {
    log.image += inv_k * image_loss(loss_space(render), target, mask_ptr, loss_settings, nullptr);
    d_renders.push_back(adjoint(parts[1].render, nullptr));  // weights half A's replay
    d_renders.push_back(adjoint(parts[0].render, nullptr));  // weights half B's replay
  }
  // Each part's replay: inv_k x its share of the samples x the (other) adjoint.
  auto t0 = Clock::now();
  double c0 = process_cpu_seconds();
  const float exposure = ExposureGradients::scale(params_, pk.view);
  for (size_t i = 0; i < parts.size(); ++i) {
    Image& d = d_renders[i];
    const float share = inv_k * float(parts[i].is.spp) / float(w.is.spp);
    for (float& x : d.pixels) x *= share;
    if (params_.find(ParamKind::Exposure)) {  // dL/dlog s_v, then d w.r.t. the unexposed render
      exposure_grads_.accumulate(pk.view, d, parts[i].render);
      for (float& x : d.pixels) x *= exposure;
    }
    if (all_zero(d)) continue;
    const Primal& q = parts[i];
    render_path_backward_ranks(*comm_, *tracer_, w.cam, q.is, d, grads_, control, q.cache ? &q.bands : nullptr);
  }
  log.backward_s += seconds_since(t0);
  log.backward_cpu_s += process_cpu_seconds() - c0;
}

void Optimizer::regulariser_terms(const ViewWork& w, float inv_k, bool with_gradients, const RenderControl& control,
                                  IterationLog& log) {
  const ViewPick& pk = w.pick;
  Image prior_a, prior_r;
  const double wp = log.prior_weight;
  if (wp > 0.0) {
    if (!w.view->files.prior_albedo.empty())
      prior_a = crop_image(reduce_image(dataset_->prior_albedo(pk.view), pk.factor), pk.x0, pk.y0, pk.w, pk.h);
    if (!w.view->files.prior_roughness.empty())
      prior_r = crop_image(reduce_image(dataset_->prior_roughness(pk.view), pk.factor), pk.x0, pk.y0, pk.w, pk.h);
  }
  const float lambda_tv = float(tv_weight(log.iteration - 1));
  if (!(lambda_tv > 0.0f || prior_a.width > 0 || prior_r.width > 0)) return;
  auto t0 = Clock::now();
  AovSettings as;
  as.interaction = w.is.interaction;
  as.spp = 1;
  as.seed = w.is.seed;
  Image alb, rough, coverage;
  // The maps' walks are kept for their adjoint below (no second traversal).
  MaterialMapWalks walks;
  render_material_maps_ranks(*comm_, tracer_->accel(), w.cam, as, control, &alb, &rough, &coverage,
                             with_gradients ? &walks : nullptr);
  Image aov_mask(pk.w, pk.h, {"A"});
  size_t n_aov = 0;
  for (size_t p = 0; p < w.px; ++p) {
    bool in = w.target_alpha.pixels[p] >= settings_.mask_threshold && coverage.pixels[p] > w.is.interaction.tau_g;
    aov_mask.pixels[p] = in ? 1.0f : 0.0f;
    n_aov += in;
  }
  if (n_aov > 0) {
    Image d_alb(pk.w, pk.h, {"R", "G", "B"}), d_rough(pk.w, pk.h, {"Y"});
    auto accumulate = [](Image& dst, const Image& src, float f) {
      for (size_t i = 0; i < dst.pixels.size(); ++i) dst.pixels[i] += f * src.pixels[i];
    };
    if (lambda_tv > 0.0f) {
      Image da, dr;
      const Image alb_guide = settings_.tv_chroma > 0.0f ? chroma_guide(w.target_rgb, settings_.tv_chroma) : w.target;
      double tv = edge_aware_tv(alb, alb_guide, &aov_mask, with_gradients ? &da : nullptr) +
                  edge_aware_tv(rough, w.target, &aov_mask, with_gradients ? &dr : nullptr);
      log.tv += inv_k * lambda_tv * tv;
      if (with_gradients) {
        accumulate(d_alb, da, inv_k * lambda_tv);
        accumulate(d_rough, dr, inv_k * lambda_tv);
      }
    }
    if (prior_a.width > 0) {
      Image d;
      log.prior += inv_k * wp * prior_l2(alb, prior_a, &aov_mask, with_gradients ? &d : nullptr);
      if (with_gradients) accumulate(d_alb, d, float(inv_k * wp));
    }
    if (prior_r.width > 0) {
      Image d;
      log.prior += inv_k * wp * prior_l2(rough, prior_r, &aov_mask, with_gradients ? &d : nullptr);
      if (with_gradients) accumulate(d_rough, d, float(inv_k * wp));
    }
    if (with_gradients) render_aov_backward_ranks(*comm_, tracer_->accel(), w.cam, as, &d_alb, &d_rough, grads_, &walks);
  }
  log.regulariser_s += seconds_since(t0);
}

IterationLog Optimizer::evaluate(int it, bool with_gradients, const std::atomic<bool>* cancel) {
  const auto t_start = Clock::now();
  IterationLog log;
  log.iteration = it + 1;
  log.prior_weight = prior_weight(it);
  grads_.set_zero();
  balance_grad_ = {0.0, 0.0, 0.0};
  exposure_grads_.reset(dataset_->size());
  RenderControl control;
  control.cancel = cancel;
  const auto picks = pick_views(it);
  log.level = picks.empty() ? 1 : picks.front().factor;
  const float inv_k = 1.0f / float(picks.size());
  for (size_t v = 0; v < picks.size(); ++v) {
    const ViewWork w = view_work(it, v, picks[v]);
    if (!log.views.empty()) log.views += "+";
    log.views += w.view->camera.name;
    // The balance's derivative (light_balance.h) counts the image term only: by
    // linearity, its change across image_term on this rank's gradients.
    const bool balance = with_gradients && params_.find(ParamKind::LightBalance);
    const float up_step = float(settings_.params.lr_balance * lr_factor(it));  // the largest step Adam takes
    const auto d0 = balance ? light_balance_derivative(params_, *scene_, grads_, up_step) : std::array<double, 3>{};
    image_term(w, inv_k, with_gradients, control, log);
    if (balance) {
      const auto d1 = light_balance_derivative(params_, *scene_, grads_, up_step);
      for (int c = 0; c < 3; ++c) balance_grad_[c] += d1[c] - d0[c];
    }
    regulariser_terms(w, inv_k, with_gradients, control, log);
    if (cancel && cancel->load()) throw Cancelled();
  }
  if (with_gradients) {
    allreduce_gradients(*comm_, grads_);  // data-parallel: the ranks' bands summed in rank order
    comm_->allreduce_sum(balance_grad_.data(), balance_grad_.size());
    if (settings_.lambda_albedo_grey > 0.0f && params_.find(ParamKind::LightBalance)) {  // after the sum: once
      const auto prior = albedo_chroma_prior(params_, *scene_);
      for (int c = 0; c < 3; ++c) balance_grad_[c] += double(settings_.lambda_albedo_grey) * prior[c];
    }
  }
  log.loss = log.image + log.tv + log.prior;
  log.seconds = seconds_since(t_start);
  return log;
}

}  // namespace ptir
