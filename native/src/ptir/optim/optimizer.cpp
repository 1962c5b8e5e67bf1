#include "ptir/optim/optimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <functional>
#include <sstream>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "ptir/core/error.h"
#include "ptir/math/rng.h"
#include "ptir/render/aov.h"
#include "ptir/render/aov_backward.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/transport/orient_normals.h"

namespace ptir {

namespace fs = std::filesystem;

float srgb_encode_unclamped(float c) {
  c = std::max(c, 0.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

float srgb_encode_derivative(float c) {
  c = std::max(c, 0.0f);
  return c <= 0.0031308f ? 12.92f : (1.055f / 2.4f) * std::pow(c, 1.0f / 2.4f - 1.0f);
}

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

Image crop_image(const Image& img, int x0, int y0, int w, int h) {
  if (x0 == 0 && y0 == 0 && w == img.width && h == img.height) return img;
  Image out(w, h, img.channel_names);
  for (int y = 0; y < h; ++y)
    std::memcpy(&out.pixels[size_t(y) * w * img.channels], &img.pixels[(size_t(y + y0) * img.width + x0) * img.channels],
                sizeof(float) * size_t(w) * img.channels);
  return out;
}

std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

uint64_t hash_floats(uint64_t h, const float* p, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    uint32_t bits;
    std::memcpy(&bits, &p[i], 4);
    h = hash_combine(h, bits);
  }
  return h;
}

bool all_zero(const Image& img) {
  for (float v : img.pixels)
    if (v != 0.0f) return false;
  return true;
}

}  // namespace

// The albedo and roughness AOVs (1 sample at each pixel centre) in one walk per
// pixel: exactly what render_aov(Albedo) and render_aov(Roughness) give with
// spp = 1 (same ray, same pick key; values where the primary ray found a valid
// interaction or a mesh, else 0), plus the coverage min(1, opacity).
void render_material_maps(const SceneAccel& accel, const Camera& cam, const AovSettings& as, const RenderControl& control,
                          Image* albedo, Image* roughness, Image* coverage) {
  *albedo = Image(cam.width, cam.height, {"R", "G", "B"});
  *roughness = Image(cam.width, cam.height, {"Y"});
  *coverage = Image(cam.width, cam.height, {"A"});
  tbb::parallel_for(tbb::blocked_range<int>(0, cam.height, 4), [&](const tbb::blocked_range<int>& r) {
    if (control.cancel && control.cancel->load()) return;
    for (int y = r.begin(); y < r.end(); ++y)
      for (int x = 0; x < cam.width; ++x) {
        Rng rng(as.seed, cam.full_pixel_index(x, y), 0);
        Ray ray = cam.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
        AovSample smp = trace_aov(accel, ray, as, rng.key(), false);
        const size_t p = size_t(y) * cam.width + x;
        if (smp.hit) {
          albedo->pixels[3 * p] = smp.albedo.x;
          albedo->pixels[3 * p + 1] = smp.albedo.y;
          albedo->pixels[3 * p + 2] = smp.albedo.z;
          roughness->pixels[p] = smp.roughness;
        }
        coverage->pixels[p] = std::min(1.0f, smp.opacity);
      }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
}

Optimizer::Optimizer(Scene scene, std::shared_ptr<const Dataset> dataset, const OptimizerSettings& settings)
    : settings_(settings), scene_(std::make_unique<Scene>(std::move(scene))), dataset_(std::move(dataset)) {
  if (!dataset_ || dataset_->size() == 0) throw Error("the optimiser needs a dataset with at least one view");
  if (!scene_->gaussians) scene_->gaussians = std::make_shared<GaussianField>();
  if (scene_->gaussians->size() == 0 && scene_->meshes.empty()) throw Error("nothing to optimise: the scene has no Gaussians");
  if (settings_.iterations < 0) throw Error("iterations must be >= 0");
  if (settings_.integrator.spp < 1) throw Error("spp must be at least 1");
  if (settings_.integrator.max_bounces < 0) throw Error("bounces must be at least 0");
  if (settings_.views_per_iteration < 1) throw Error("views per iteration must be at least 1");
  if (settings_.crop_size < 0) throw Error("crop size must be >= 0");
  GaussianField& field = *scene_->gaussians;
  const size_t n = field.size();
  if (field.normal.size() != n) init_normals_shortest_axis(field);
  field.albedo.resize(n);
  field.roughness.resize(n);
  field.metallic.resize(n);

  install_environment(*scene_, settings_.params);
  params_ = make_parameters(*scene_, settings_.params);
  for (const ParameterGroup& g : params_.groups) adam_.emplace_back(g.raw.size(), g.lr, settings_.adam);
  apply();
  tracer_ = std::make_unique<PathTracer>(*scene_, settings_.accel);
  if (settings_.orient_normals && !field.normals_from_file && n > 0) {
    std::vector<Camera> cams = dataset_->cameras();
    int rays_per_camera = std::max(4096, int(262144 / std::max<size_t>(1, cams.size())));
    orient_normals_to_cameras(field, tracer_->accel(), cams, rays_per_camera);
  }
  grads_ = SceneGradients::zeros_like(*scene_);
  mask_box_.assign(dataset_->size(), {0, 0, -1, -1});
}

Optimizer::~Optimizer() = default;

void Optimizer::apply() { apply_parameters(params_, settings_.params, *scene_); }

double Optimizer::prior_weight(int it) const {
  if (settings_.prior_iterations <= 0) return settings_.prior_end;
  double f = std::min(1.0, double(it) / double(settings_.prior_iterations));
  return settings_.prior_start + (settings_.prior_end - settings_.prior_start) * f;
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

std::vector<Optimizer::ViewPick> Optimizer::pick_views(int it) const {
  const size_t N = dataset_->size();
  const int k = settings_.views_per_iteration;
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
    ViewPick p{perm[pos], 0, 0, dataset_->width, dataset_->height};
    const int cs = settings_.crop_size;
    if (cs > 0 && (cs < dataset_->width || cs < dataset_->height)) {
      p.w = std::min(cs, dataset_->width);
      p.h = std::min(cs, dataset_->height);
      const auto& b = mask_box(p.view);
      Rng r(hash_combine(settings_.seed, kTagCrop), uint64_t(it), uint64_t(v));
      int cx = b[0] + std::min(b[2] - b[0], int(r.at(0) * float(b[2] - b[0] + 1)));
      int cy = b[1] + std::min(b[3] - b[1], int(r.at(1) * float(b[3] - b[1] + 1)));
      p.x0 = std::clamp(cx - p.w / 2, 0, dataset_->width - p.w);
      p.y0 = std::clamp(cy - p.h / 2, 0, dataset_->height - p.h);
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
  std::vector<std::vector<float>> raw = raw_gradients(params_, grads_);
  for (auto& g : raw)
    for (float& d : g)
      if (!std::isfinite(d)) {
        d = 0.0f;
        ++nonfinite_;
      }
  for (size_t i = 0; i < params_.groups.size(); ++i) adam_[i].step(params_.groups[i].raw, raw[i]);
  apply();
  log.update_s = seconds_since(t0);
  log.seconds = seconds_since(t_start);
  log.cpu_s = process_cpu_seconds() - cpu_start;
  ++iteration_;
  log_.push_back(log);
  return log;
}

IterationLog Optimizer::evaluate(int it, bool with_gradients, const std::atomic<bool>* cancel) {
  const auto t_start = Clock::now();
  IterationLog log;
  log.iteration = it + 1;
  log.prior_weight = prior_weight(it);
  grads_.set_zero();
  RenderControl control;
  control.cancel = cancel;
  const auto picks = pick_views(it);
  const float inv_k = 1.0f / float(picks.size());
  const bool srgb = settings_.srgb_loss;
  auto encode = [srgb](float c) { return srgb ? srgb_encode_unclamped(c) : c; };
  auto encode_d = [srgb](float c) { return srgb ? srgb_encode_derivative(c) : 1.0f; };

  for (size_t v = 0; v < picks.size(); ++v) {
    const ViewPick& pk = picks[v];
    const DatasetView& view = dataset_->views[pk.view];
    if (!log.views.empty()) log.views += "+";
    log.views += view.camera.name;
    Camera cam = view.camera;
    if (pk.w != cam.width || pk.h != cam.height) cam = cam.crop(pk.x0, pk.y0, pk.w, pk.h);
    auto full = dataset_->target(pk.view);
    const Image target_rgb = crop_image(full->rgb, pk.x0, pk.y0, pk.w, pk.h);
    const Image target_alpha = crop_image(full->alpha, pk.x0, pk.y0, pk.w, pk.h);
    const size_t px = size_t(pk.w) * pk.h;

    IntegratorSettings is = settings_.integrator;
    is.seed = hash_combine(hash_combine(settings_.seed, kTagPath), hash_combine(uint64_t(it), uint64_t(v)));

    // Primal render (keeping each sample's radiance for the replay when it fits) and the image loss.
    auto t0 = Clock::now();
    double c0 = process_cpu_seconds();
    const bool cache = with_gradients && px * size_t(is.spp) * sizeof(Vec3) <= settings_.sample_cache_bytes;
    std::vector<Vec3> sample_radiance;
    Image render = render_path(*tracer_, cam, is, control, nullptr, cache ? &sample_radiance : nullptr);
    log.primal_s += seconds_since(t0);
    log.primal_cpu_s += process_cpu_seconds() - c0;
    Image pred(pk.w, pk.h, {"R", "G", "B"}), target(pk.w, pk.h, {"R", "G", "B"}), mask(pk.w, pk.h, {"A"});
    size_t masked = 0;
    for (size_t p = 0; p < px; ++p) {
      for (int c = 0; c < 3; ++c) {
        pred.pixels[p * 3 + c] = encode(render.pixels[p * 4 + c]);
        target.pixels[p * 3 + c] = encode(target_rgb.pixels[p * 3 + c]);
      }
      bool in = !full->has_alpha ||
                (target_alpha.pixels[p] >= settings_.mask_threshold && render.pixels[p * 4 + 3] >= settings_.mask_threshold);
      mask.pixels[p] = in ? 1.0f : 0.0f;
      masked += in;
    }
    if (masked > 0) {
      Image d_pred;
      log.image += inv_k * image_loss(pred, target, full->has_alpha ? &mask : nullptr, settings_.loss,
                                      with_gradients ? &d_pred : nullptr);
      if (with_gradients) {
        // Through the loss-space curve to the linear render.
        Image d_render(pk.w, pk.h, {"R", "G", "B"});
        for (size_t p = 0; p < px; ++p)
          for (int c = 0; c < 3; ++c)
            d_render.pixels[p * 3 + c] = inv_k * d_pred.pixels[p * d_pred.channels + c] * encode_d(render.pixels[p * 4 + c]);
        if (!all_zero(d_render)) {
          t0 = Clock::now();
          c0 = process_cpu_seconds();
          render_path_backward(*tracer_, cam, is, d_render, grads_, control, cache ? &sample_radiance : nullptr);
          log.backward_s += seconds_since(t0);
          log.backward_cpu_s += process_cpu_seconds() - c0;
        }
      }
    }

    // Regularisers on the primary-hit material maps.
    Image prior_a, prior_r;
    const double wp = log.prior_weight;
    if (wp > 0.0) {
      if (!view.files.prior_albedo.empty()) prior_a = crop_image(dataset_->prior_albedo(pk.view), pk.x0, pk.y0, pk.w, pk.h);
      if (!view.files.prior_roughness.empty())
        prior_r = crop_image(dataset_->prior_roughness(pk.view), pk.x0, pk.y0, pk.w, pk.h);
    }
    if (settings_.lambda_tv > 0.0f || prior_a.width > 0 || prior_r.width > 0) {
      t0 = Clock::now();
      AovSettings as;
      as.interaction = is.interaction;
      as.spp = 1;
      as.seed = is.seed;
      Image alb, rough, coverage;
      render_material_maps(tracer_->accel(), cam, as, control, &alb, &rough, &coverage);
      Image aov_mask(pk.w, pk.h, {"A"});
      size_t n_aov = 0;
      for (size_t p = 0; p < px; ++p) {
        bool in = target_alpha.pixels[p] >= settings_.mask_threshold && coverage.pixels[p] > is.interaction.tau_g;
        aov_mask.pixels[p] = in ? 1.0f : 0.0f;
        n_aov += in;
      }
      if (n_aov > 0) {
        Image d_alb(pk.w, pk.h, {"R", "G", "B"}), d_rough(pk.w, pk.h, {"Y"});
        auto accumulate = [](Image& dst, const Image& src, float w) {
          for (size_t i = 0; i < dst.pixels.size(); ++i) dst.pixels[i] += w * src.pixels[i];
        };
        if (settings_.lambda_tv > 0.0f) {
          Image da, dr;
          double tv = edge_aware_tv(alb, target, &aov_mask, with_gradients ? &da : nullptr) +
                      edge_aware_tv(rough, target, &aov_mask, with_gradients ? &dr : nullptr);
          log.tv += inv_k * settings_.lambda_tv * tv;
          if (with_gradients) {
            accumulate(d_alb, da, inv_k * settings_.lambda_tv);
            accumulate(d_rough, dr, inv_k * settings_.lambda_tv);
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
        if (with_gradients) render_aov_backward(tracer_->accel(), cam, as, &d_alb, &d_rough, grads_);
      }
      log.regulariser_s += seconds_since(t0);
    }
    if (cancel && cancel->load()) throw Cancelled();
  }

  log.loss = log.image + log.tv + log.prior;
  log.seconds = seconds_since(t_start);
  return log;
}

Fingerprint Optimizer::fingerprint() const {
  const GaussianField& f = *scene_->gaussians;
  const IntegratorSettings& is = settings_.integrator;
  const ParameterSettings& ps = settings_.params;
  uint64_t geo = 0;
  geo = hash_floats(geo, reinterpret_cast<const float*>(f.position.data()), 3 * f.size());
  geo = hash_floats(geo, reinterpret_cast<const float*>(f.scale.data()), 3 * f.size());
  geo = hash_floats(geo, reinterpret_cast<const float*>(f.rotation.data()), 4 * f.size());
  geo = hash_floats(geo, f.opacity.data(), f.size());
  for (const TriangleMesh& m : scene_->meshes) geo = hash_floats(geo, reinterpret_cast<const float*>(m.vertices.data()), 3 * m.vertices.size());
  uint64_t views = 0;
  for (const DatasetView& v : dataset_->views) {
    views = hash_combine(views, std::hash<std::string>()(v.camera.name));
    views = hash_floats(views, &v.camera.cam_to_world.linear.m[0][0], 9);
    views = hash_floats(views, &v.camera.cam_to_world.translation.x, 3);
  }
  std::ostringstream hx, hv;
  hx << std::hex << geo;
  hv << std::hex << views;
  return {
      {"gaussians", std::to_string(f.size())},
      {"meshes", std::to_string(scene_->meshes.size())},
      {"lights", std::to_string(scene_->emitters.size())},
      {"geometry_hash", hx.str()},
      {"views", std::to_string(dataset_->size())},
      {"views_hash", hv.str()},
      {"image_size", std::to_string(dataset_->width) + "x" + std::to_string(dataset_->height)},
      {"priors", dataset_->has_priors() ? "yes" : "no"},
      {"seed", std::to_string(settings_.seed)},
      {"spp", std::to_string(is.spp)},
      {"bounces", std::to_string(is.max_bounces)},
      {"brdf", to_string(is.brdf)},
      {"interaction", is.interaction.mode == InteractionMode::Discrete ? "discrete" : "aggregate"},
      {"tau_g", num(is.interaction.tau_g)},
      {"geometric_criterion", is.geometric_criterion ? "1" : "0"},
      {"self_intersection", is.self_intersection == SelfIntersection::FixedOffset ? "fixed" : "backface"},
      {"k", std::to_string(settings_.accel.k)},
      {"views_per_iteration", std::to_string(settings_.views_per_iteration)},
      {"crop", std::to_string(settings_.crop_size)},
      {"loss", num(settings_.loss.lambda_ssim) + (settings_.loss.binomial_filter ? " blur" : " noblur") +
                   (settings_.srgb_loss ? " srgb" : " linear")},
      {"mask_threshold", num(settings_.mask_threshold)},
      {"lambda_tv", num(settings_.lambda_tv)},
      {"prior", num(settings_.prior_start) + " " + num(settings_.prior_end) + " " + std::to_string(settings_.prior_iterations)},
      {"init", num(ps.init_albedo) + " " + num(ps.init_roughness) + " " + num(ps.init_metallic) + " " +
                   num(ps.init_metallic_optimised)},
      {"metallic", ps.optimize_metallic ? "optimised" : "fixed"},
      {"env", ps.env == EnvMode::LatLong ? "latlong " + std::to_string(ps.env_width) + "x" + std::to_string(ps.env_height) +
                                               " " + num(ps.env_init)
                                         : "sg " + std::to_string(ps.sg_lobes)},
      {"env_init", ps.env_init_path.empty() ? std::string("constant") : fs::absolute(ps.env_init_path).string()},
      {"env_optimised", ps.optimize_env ? "1" : "0"},
      {"mesh_materials", ps.optimize_meshes ? "optimised" : "fixed"},
      {"lr", num(ps.lr_albedo) + " " + num(ps.lr_roughness) + " " + num(ps.lr_metallic) + " " + num(ps.lr_env) + " " +
                 num(ps.lr_mesh)},
      {"adam", num(settings_.adam.beta1) + " " + num(settings_.adam.beta2) + " " + num(settings_.adam.eps)},
      {"orient_normals", settings_.orient_normals ? "1" : "0"},
  };
}

Checkpoint Optimizer::checkpoint() const {
  Checkpoint c;
  c.iteration = uint64_t(iteration_);
  c.fingerprint = fingerprint();
  for (size_t i = 0; i < params_.groups.size(); ++i) {
    CheckpointGroup g;
    g.kind = params_.groups[i].kind;
    g.lr = params_.groups[i].lr;
    g.raw = params_.groups[i].raw;
    g.m = adam_[i].m;
    g.v = adam_[i].v;
    g.adam_t = adam_[i].t;
    c.groups.push_back(std::move(g));
  }
  c.normals = scene_->gaussians->normal;
  c.log = log_;
  return c;
}

void Optimizer::restore(const Checkpoint& c, const std::string& path) {
  check_fingerprint(path, c.fingerprint, fingerprint());
  if (c.groups.size() != params_.groups.size()) throw Error(path, "checkpoint has a different set of parameter groups");
  for (size_t i = 0; i < c.groups.size(); ++i) {
    const CheckpointGroup& g = c.groups[i];
    if (g.kind != params_.groups[i].kind || g.raw.size() != params_.groups[i].raw.size())
      throw Error(path, std::string("checkpoint parameter group '") + param_kind_name(g.kind) + "' does not match");
  }
  if (c.normals.size() != scene_->gaussians->size()) throw Error(path, "checkpoint has a different Gaussian count");
  for (size_t i = 0; i < c.groups.size(); ++i) {
    const CheckpointGroup& g = c.groups[i];
    params_.groups[i].raw = g.raw;
    params_.groups[i].lr = g.lr;
    adam_[i].lr = g.lr;
    adam_[i].m = g.m;
    adam_[i].v = g.v;
    adam_[i].t = g.adam_t;
  }
  scene_->gaussians->normal = c.normals;
  iteration_ = int(c.iteration);
  log_ = c.log;
  apply();
}

std::string Optimizer::log_csv() const {
  std::ostringstream s;
  s << "iteration,loss,image,tv,prior,prior_weight,seconds,primal_s,backward_s,regulariser_s,update_s,cpu_s,primal_cpu_s,"
       "backward_cpu_s,views\n";
  for (const IterationLog& l : log_) {
    s << l.iteration << ',' << num(l.loss) << ',' << num(l.image) << ',' << num(l.tv) << ',' << num(l.prior) << ','
      << num(l.prior_weight) << ',' << num(l.seconds) << ',' << num(l.primal_s) << ',' << num(l.backward_s) << ','
      << num(l.regulariser_s) << ',' << num(l.update_s) << ',' << num(l.cpu_s) << ',' << num(l.primal_cpu_s) << ','
      << num(l.backward_cpu_s) << ',' << l.views << '\n';
  }
  return s.str();
}

Image Optimizer::environment_image() const {
  const SceneEnvironment& env = scene_->environment;
  if (env.latlong) {
    const Environment& e = *env.latlong;
    Image img(e.width(), e.height(), {"R", "G", "B"});
    img.pixels = e.texels();
    return img;
  }
  if (env.sg) return env.sg->to_latlong(settings_.params.env_width, settings_.params.env_height);
  return Image(1, 1, {"R", "G", "B"});
}

void Optimizer::write_outputs(const std::string& dir) const {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) throw Error(dir, "cannot create the output folder");
  const fs::path out(dir);
  save_gaussians((out / "gaussians.ply").string(), *scene_->gaussians);
  write_image((out / "env.exr").string(), environment_image(), Encoding::Colour);
  write_text_atomic((out / "log.csv").string(), log_csv());
  if (scene_->environment.sg) {
    const SgEnvironment& sg = *scene_->environment.sg;
    std::ostringstream s;
    s << "{\"gamma\": " << num(sg.gamma()) << ", \"lobes\": [";
    for (int i = 0; i < sg.size(); ++i) {
      Vec3 a = sg.axes()[size_t(i)], r = sg.raw()[size_t(i)], c = sg.amplitude(i);
      s << (i ? ",\n  " : "\n  ") << "{\"axis\": [" << num(a.x) << ", " << num(a.y) << ", " << num(a.z)
        << "], \"sharpness\": " << num(sg.sharpness()[size_t(i)]) << ", \"raw\": [" << num(r.x) << ", " << num(r.y) << ", "
        << num(r.z) << "], \"amplitude\": [" << num(c.x) << ", " << num(c.y) << ", " << num(c.z) << "]}";
    }
    s << "\n]}\n";
    write_text_atomic((out / "env_sg.json").string(), s.str());
  }
  if (params_.find(ParamKind::MeshColour)) {
    std::ostringstream s;
    s << "{\"meshes\": [";
    for (size_t i = 0; i < scene_->meshes.size(); ++i) {
      const TriangleMesh& m = scene_->meshes[i];
      Vec3 b = m.material.base_colour;
      s << (i ? ",\n  " : "\n  ") << "{\"name\": \"" << m.name << "\", \"base_colour\": [" << num(b.x) << ", " << num(b.y)
        << ", " << num(b.z) << "], \"roughness\": " << num(m.material.roughness)
        << ", \"metallic\": " << num(m.material.metallic) << "}";
    }
    s << "\n]}\n";
    write_text_atomic((out / "mesh_materials.json").string(), s.str());
  }
}

RunResult run_optimizer(Optimizer& opt, const RunOptions& o) {
  const bool write = !o.out_dir.empty();
  const std::string ckpt = write ? (fs::path(o.out_dir) / "checkpoint.bin").string() : "";
  if (write) {
    std::error_code ec;
    fs::create_directories(o.out_dir, ec);
    if (!fs::is_directory(o.out_dir)) throw Error(o.out_dir, "cannot create the output folder");
  }
  bool cancelled = false;
  while (opt.iteration() < opt.settings().iterations) {
    if (o.cancel && o.cancel->load()) {
      cancelled = true;
      break;
    }
    IterationLog log;
    try {
      log = opt.step(o.cancel);
    } catch (const Cancelled&) {
      cancelled = true;
      break;
    }
    bool go_on = o.on_iteration ? o.on_iteration(log) : true;
    if (write && o.checkpoint_every > 0 && opt.iteration() % o.checkpoint_every == 0 &&
        opt.iteration() < opt.settings().iterations) {
      opt.save_checkpoint(ckpt);
      write_text_atomic((fs::path(o.out_dir) / "log.csv").string(), opt.log_csv());
    }
    if (!go_on) {
      cancelled = true;
      break;
    }
  }
  if (write) {
    opt.save_checkpoint(ckpt);
    opt.write_outputs(o.out_dir);
  }
  return cancelled ? RunResult::Cancelled : RunResult::Finished;
}

}  // namespace ptir
