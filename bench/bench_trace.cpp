// bench_trace: how much slower is tracing Gaussians than tracing triangles?
//
// For one splat file and one camera it measures
//   - Gaussian primary rays/s: render_aov (opacity, pixel centres, 1 spp), i.e. the
//     full ordered k-buffer walk plus compositing with early termination at
//     T < 0.001, and the mean hits per ray from TraceStats;
//   - triangle primary rays/s: SceneAccel::closest_mesh (a triangles-only Embree
//     scene) over the same rays, on a mesh with one triangle per Gaussian;
// single-threaded and multi-threaded (TBB), for several k-buffer sizes.
//
// The comparison mesh replaces each Gaussian by one triangle in the plane of its
// two longest axes, inscribed in its 2-sigma ellipse: the same count, the same
// positions and roughly the same footprint, so both scenes give the BVH a similar
// amount of overlap. A mesh renderer only needs the closest hit; Gaussians need
// every hit in order until the ray is opaque — that is the cost being measured.
#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/render/aov.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussian_ply.h"

using namespace ptir;

namespace {

using Clock = std::chrono::steady_clock;

// Median wall time of `repeat` runs of fn (after one warm-up run).
double median_seconds(int repeat, const std::function<void()>& fn) {
  fn();
  std::vector<double> t;
  for (int i = 0; i < repeat; ++i) {
    auto t0 = Clock::now();
    fn();
    t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// Runs fn with TBB limited to `threads` workers (0: TBB's default, all cores).
template <class Fn>
auto with_threads(int threads, Fn&& fn) {
  if (threads <= 0) return fn();
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
  return fn();
}

// One triangle per Gaussian, in the plane of its two longest axes (see the header).
TriangleMesh triangle_per_gaussian(const GaussianField& f) {
  TriangleMesh mesh;
  mesh.name = "triangle_per_gaussian";
  mesh.vertices.reserve(3 * f.size());
  mesh.triangles.reserve(f.size());
  for (size_t i = 0; i < f.size(); ++i) {
    Mat3 r = f.rotation_matrix(i);
    Vec3 s = f.scale[i];
    int shortest = (s.x <= s.y && s.x <= s.z) ? 0 : (s.y <= s.z ? 1 : 2);
    int a = (shortest + 1) % 3, b = (shortest + 2) % 3;
    Vec3 ua = r.col(a) * (2.0f * s[a]), ub = r.col(b) * (2.0f * s[b]);
    uint32_t base = uint32_t(mesh.vertices.size());
    for (int k = 0; k < 3; ++k) {
      float theta = 0.5f * kPi + float(k) * 2.0f * kPi / 3.0f;
      mesh.vertices.push_back(f.position[i] + std::cos(theta) * ua + std::sin(theta) * ub);
    }
    mesh.triangles.push_back({base, base + 1, base + 2});
  }
  return mesh;
}

struct Options {
  std::string gaussians, cameras;
  int frame = 0;
  int size = 256;
  int repeat = 5;
  float zoom = 1.0f;  // narrows the field of view so the object fills more of the image
  std::vector<int> ks = {8, 16, 32};
};

struct MeshResult {
  double rays_per_s = 0;
  double hit_fraction = 0;
};

MeshResult bench_triangles(const SceneAccel& accel, const std::vector<Ray>& rays, int threads, int repeat) {
  std::atomic<size_t> hits{0};
  auto trace_all = [&] {
    hits = 0;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, rays.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
      size_t local = 0;
      for (size_t i = r.begin(); i < r.end(); ++i) local += accel.closest_mesh(rays[i]).valid ? 1 : 0;
      hits += local;
    });
  };
  double secs = with_threads(threads, [&] { return median_seconds(repeat, trace_all); });
  return {double(rays.size()) / secs, double(hits) / double(rays.size())};
}

int run(const Options& o) {
  auto t0 = Clock::now();
  GaussianField field = load_gaussians(o.gaussians);
  std::vector<Camera> cams = load_transforms_json(o.cameras, o.size, o.size);
  if (o.frame < 0 || o.frame >= int(cams.size())) throw Error(o.cameras, "frame out of range");
  Camera cam = cams[o.frame];
  cam.fov_x = 2.0f * std::atan(std::tan(0.5f * cam.fov_x) / o.zoom);
  const double n_rays = double(cam.width) * cam.height;
  std::printf("bench_trace: %zu Gaussians, %dx%d primary rays (frame %d, zoom %g), %u hardware threads, median of %d"
              " runs (loaded in %.1f s)\n",
              field.size(), cam.width, cam.height, o.frame, o.zoom, std::thread::hardware_concurrency(), o.repeat,
              std::chrono::duration<double>(Clock::now() - t0).count());

  // Triangles: the same pixel-centre rays render_aov traces at 1 spp.
  std::vector<Ray> rays;
  rays.reserve(size_t(n_rays));
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) rays.push_back(cam.generate_ray(float(x) + 0.5f, float(y) + 0.5f));
  std::vector<TriangleMesh> meshes = {triangle_per_gaussian(field)};
  GaussianField none;
  SceneAccel tri_accel(none, meshes);
  std::printf("triangle mesh: %zu triangles (one per Gaussian, in its 2-sigma ellipse); %.1f%% of rays hit\n",
              meshes[0].triangles.size(), 100.0 * bench_triangles(tri_accel, rays, 0, 1).hit_fraction);

  std::printf("\n%4s  %-7s  %16s  %16s  %7s  %9s  %11s  %10s  %8s\n", "k", "threads", "Gaussian rays/s",
              "triangle rays/s", "ratio", "hits/ray", "rounds/ray", "boxes/ray", "coverage");
  AovSettings settings;  // pixel centres, aggregate interaction
  for (int k : o.ks) {
    AccelSettings as;
    as.k = k;
    SceneAccel accel(field, {}, as);
    for (int threads : {1, 0}) {
      TraceStats stats;
      Image img;
      double secs = with_threads(threads, [&] {
        return median_seconds(o.repeat, [&] {
          stats = TraceStats();
          img = render_aov(accel, cam, Aov::Opacity, settings, {}, &stats);
        });
      });
      // Triangles right after, under the same machine load: the ratio is what counts.
      MeshResult tri = bench_triangles(tri_accel, rays, threads, o.repeat);
      double coverage = 0;
      for (float a : img.pixels) coverage += a;
      double g = n_rays / secs;
      double t = tri.rays_per_s;
      std::printf("%4d  %-7s  %16.0f  %16.0f  %6.1fx  %9.2f  %11.2f  %10.2f  %7.1f%%\n", k, threads == 1 ? "1" : "all", g,
                  t, t / g, double(stats.hits) / n_rays, double(stats.rounds) / n_rays,
                  double(stats.candidates) / n_rays, 100.0 * coverage / n_rays);
    }
  }
  std::printf("\nratio = triangle rays/s / Gaussian rays/s (how many times slower the Gaussian walk is);\n"
              "hits: Gaussians composited; boxes: Gaussian proxy boxes entered (intersection callbacks)\n");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Gaussian vs triangle primary-ray throughput (a benchmark, not a test)"};
  Options o;
  app.add_option("--gaussians", o.gaussians, "3DGS .ply")->required();
  app.add_option("--cameras", o.cameras, "NeRF-synthetic transforms_*.json")->required();
  app.add_option("--frame", o.frame, "frame index")->capture_default_str();
  app.add_option("--size", o.size, "image width and height")->capture_default_str();
  app.add_option("--repeat", o.repeat, "timed runs per measurement (median)")->capture_default_str();
  app.add_option("--zoom", o.zoom, "divide tan(fov/2) by this (object fills more rays)")->capture_default_str();
  app.add_option("--k", o.ks, "k-buffer sizes")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_trace: error: %s\n", e.what());
    return 1;
  }
}
