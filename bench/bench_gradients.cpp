// bench_gradients: the inversion's two passes on a scene file, per thread count.
//
// For each thread count: the primal render keeping every sample's radiance
// (render_path), then the replay (render_path_backward) of a fixed image adjoint
// (1 / pixels on every channel), the replay reading the ray outcomes and the walks
// the primal kept (as the optimiser does; --walk-mb; "replay traced s": tracing
// them again), with the inversion's estimator (every light, no roulette). Prints primal and replay seconds, path samples
// per second (pixels x spp / (primal + replay)), replay / primal, the tile
// reduction's figures (tiles, Gaussian entries, largest tile buffer, buffers in
// flight, seconds in the in-order stage) and checks that every thread count gives
// bit-identical gradients. Then the memory/time model of the reduction at more
// threads: what the per-thread dense copies cost (threads x parameters x 20 B,
// zeroed and summed serially) against the tiles (kTokensPerThread buffers per thread x the
// largest tile buffer; the in-order stage bounds the speed-up at
// (primal-free replay CPU time) / (stage time)).
// Then process CPU time / threads (primal, replay) and the samples/s they give:
// on a shared machine, what the passes cost on idle cores; last, the walks kept
// (MB of chunks, % of samples). Timed passes reuse the buffers of an untimed
// first one, as the optimiser's iterations do (--cold: time the first).
// A benchmark, not a test: compare within one run.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/optim/optimizer.h"
#include "ptir/render/render_path.h"
#include "ptir/render/tile_reduce.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/gradients.h"

using namespace ptir;

namespace {

double wall() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
// Process CPU time: what the work costs when the machine is shared (wall time counts the waits).
double cpu() { return double(std::clock()) / CLOCKS_PER_SEC; }

bool same_floats(const SceneGradients& a, const SceneGradients& b) {
  auto eq = [](const auto& x, const auto& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0;
  };
  return eq(a.gaussian_albedo, b.gaussian_albedo) && eq(a.gaussian_roughness, b.gaussian_roughness) &&
         eq(a.gaussian_metallic, b.gaussian_metallic) && eq(a.mesh_base_colour, b.mesh_base_colour) &&
         eq(a.environment, b.environment);
}

struct Options {
  std::string scene;
  int spp = 16, bounces = 2, size = 0;
  bool traced = true;  // also time the replay that traces the shadow rays again
  bool cold = false;   // time the first pass (fresh buffers)
  std::vector<int> threads = {1, 2};
  std::vector<int> model_threads = {16, 64};
  int walk_mb = 256;
};

int run(const Options& o) {
  Scene scene = load_scene_json(o.scene);
  if (scene.cameras.empty()) throw Error(o.scene + ": the scene has no camera");
  Camera cam = scene.cameras.front();
  if (o.size > 0 && (o.size < cam.width || o.size < cam.height)) {  // the centre of the view
    const int w = std::min(o.size, cam.width), h = std::min(o.size, cam.height);
    cam = cam.crop((cam.width - w) / 2, (cam.height - h) / 2, w, h);
  }
  // The inversion's estimator (every light at every vertex, no roulette: path replay
  // needs it), with the scene's geometry settings, as `ptir optimize` sets it up.
  IntegratorSettings is = scene.integrator;
  const IntegratorSettings inv = inversion_integrator();
  is.light_selection = inv.light_selection;
  is.russian_roulette = inv.russian_roulette;
  is.min_specular_probability = inv.min_specular_probability;
  is.spp = o.spp;
  is.max_bounces = o.bounces;
  PathTracer tracer(scene);
  const size_t pixels = size_t(cam.width) * cam.height, n = scene.gaussians ? scene.gaussians->size() : 0;
  Image d_image(cam.width, cam.height, {"R", "G", "B"});
  for (float& v : d_image.pixels) v = 1.0f / float(pixels);
  std::printf("bench_gradients: %s, %zu Gaussians, %zu meshes, %dx%d, %d spp, %d bounces, env %zu parameters\n",
              o.scene.c_str(), n, scene.meshes.size(), cam.width, cam.height, o.spp, o.bounces,
              scene.environment.parameter_count());
  std::printf("%7s %9s %9s %16s %8s %13s %7s %9s %11s %7s %9s %9s %9s %9s %8s %9s %7s\n", "threads", "primal s", "replay s",
              "replay traced s", "Msps", "replay/primal", "tiles", "entries", "tile KB max", "buffers", "stage s", "gradients",
              "cpu/t pr", "cpu/t re", "cpu Msps", "walks MB", "kept %");
  SceneGradients reference;
  double stage_s = 0.0, replay_cpu_s = 0.0;
  size_t peak_tile = 0;
  // The buffers of an iteration (radiance, ray outcomes, kept walks) live across
  // the runs, as in the optimiser, which reuses them every iteration; a first
  // untimed pass touches their pages (--cold: time the first pass instead).
  WalkStore walks(size_t(o.walk_mb) << 20);
  ReplayCache cache;
  cache.walks = o.walk_mb > 0 ? &walks : nullptr;
  if (!o.cold) {
    SceneGradients g = SceneGradients::zeros_like(scene);
    render_path(tracer, cam, is, {}, nullptr, &cache);
    render_path_backward(tracer, cam, is, d_image, g, {}, &cache);
  }
  for (int t : o.threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(t));
    double t0 = wall(), c0 = cpu();
    render_path(tracer, cam, is, {}, nullptr, &cache);
    double primal = wall() - t0, primal_cpu = cpu() - c0;
    SceneGradients g = SceneGradients::zeros_like(scene), traced = g;
    TileReduceStats st;
    t0 = wall(), c0 = cpu();
    render_path_backward(tracer, cam, is, d_image, g, {}, &cache, &st);
    double replay = wall() - t0, replay_cpu = cpu() - c0;
    double replay_traced = 0.0;
    if (o.traced) {
      ReplayCache radiance = ReplayCache::radiance_only();
      radiance.radiance = cache.radiance;
      t0 = wall();
      render_path_backward(tracer, cam, is, d_image, traced, {}, &radiance);
      replay_traced = wall() - t0;
    } else {
      traced = g;
    }
    bool same = same_floats(g, traced) && (reference.gaussian_albedo.empty() || same_floats(g, reference));
    if (reference.gaussian_albedo.empty()) reference = g;
    std::printf("%7d %9.3f %9.3f %16.3f %8.3f %13.2f %7zu %9zu %11.1f %7zu %9.4f %9s %9.3f %9.3f %8.3f %9.1f %7.1f\n", t, primal,
                replay, replay_traced, double(pixels) * o.spp / (primal + replay) * 1e-6, replay / primal, st.tiles,
                st.entries, st.peak_tile_bytes / 1024.0, st.buffers, st.stage_seconds, same ? "identical" : "DIFFERENT",
                primal_cpu / t, replay_cpu / t, double(pixels) * o.spp / ((primal_cpu + replay_cpu) / t) * 1e-6,
                walks.bytes() / 1e6, walks.size() ? 100.0 * double(walks.kept()) / double(walks.size()) : 0.0);
    if (t == 1) replay_cpu_s = replay, stage_s = st.stage_seconds;
    peak_tile = std::max(peak_tile, st.peak_tile_bytes);
  }
  // Model of the reduction at more threads, from the one-thread figures.
  const double dense_bytes = double(n) * 20.0 + double(scene.meshes.size()) * 20.0 + 4.0 * scene.environment.parameter_count();
  SceneGradients a = SceneGradients::zeros_like(scene), b = SceneGradients::zeros_like(scene);
  double t0 = wall();
  for (int r = 0; r < 8; ++r) {
    b.set_zero();
    a.add(b);
  }
  const double copy_s = (wall() - t0) / 8.0;  // zero one copy + add it: the old per-thread cost
  std::printf("\nreduction model (one dense copy = %.1f MB, zero + add %.4f s; tile buffer max %.1f KB, %d per thread):\n",
              dense_bytes / 1e6, copy_s, peak_tile / 1024.0, kTokensPerThread);
  std::printf("%7s %16s %16s %16s %18s %20s\n", "threads", "old memory MB", "old serial s", "tiles memory MB",
              "tiles max speed-up", "old MB at 3M Gauss.");
  for (int t : o.model_threads)
    std::printf("%7d %16.1f %16.3f %16.1f %18.0f %20.0f\n", t, t * dense_bytes / 1e6, t * copy_s,
                double(kTokensPerThread) * t * peak_tile / 1e6, stage_s > 0.0 ? replay_cpu_s / stage_s : 0.0,
                t * 3e6 * 20.0 / 1e6);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"bench_gradients: primal and replay of the inversion per thread count"};
  app.add_option("scene", o.scene, "scene JSON (its first camera)")->required();
  app.add_option("--spp", o.spp);
  app.add_option("--bounces", o.bounces);
  app.add_option("--size", o.size, "crop the camera to its central size x size (0: whole image)");
  app.add_option("--threads", o.threads);
  app.add_option("--model-threads", o.model_threads);
  app.add_option("--walk-mb", o.walk_mb, "budget of the primal's kept walks (WalkStore; 0: the replay walks again)");
  app.add_flag("--cold", o.cold, "time the first pass (fresh buffers: page faults included) instead of a warm one");
  app.add_flag("!--no-traced", o.traced, "skip the replay that traces the shadow rays again (for profiles)");
  CLI11_PARSE(app, argc, argv);
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_gradients: error: %s\n", e.what());
    return 1;
  }
}
