// bench_trace: how much slower is tracing Gaussians than tracing triangles?
//
// For one splat file and one camera it measures primary rays (pixel centres, 1 spp):
//   - Gaussian rays/s of the opacity AOV, i.e. the full ordered k-buffer walk plus
//     compositing (InteractionBuilder) with early termination at T < 0.001:
//       render_aov      the library's renderer, as it is;
//       aov 1x1         the same per-pixel work here, one SceneAccel::walk per ray;
//       aov WxH         the same with SceneAccel::walk_packet over WxH pixel blocks;
//     and of the traversal alone (the hits in order, composited into opacity only,
//     no material fetched; the counterpart of a closest hit):
//       trav 1x1, trav WxH;
//   - triangle rays/s: SceneAccel::closest_mesh (a triangles-only Embree scene,
//     rtcIntersect1) over the same rays, on a mesh with one triangle per Gaussian;
// single-threaded (CPU time: robust on a shared machine) and multi-threaded (TBB,
// wall time), for several k-buffer sizes. Every variant must produce the image
// render_aov produces (checked).
//
// The comparison mesh replaces each Gaussian by one triangle in the plane of its
// two longest axes, inscribed in its 2-sigma ellipse: the same count, the same
// positions and roughly the same footprint, so both scenes give the BVH a similar
// amount of overlap. A mesh renderer only needs the closest hit; Gaussians need
// every hit in order until the ray is opaque — that is the cost being measured.
#include <CLI/CLI.hpp>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "ptir/accel/scene_accel.h"
#include "ptir/core/error.h"
#include "ptir/math/rng.h"
#include "ptir/render/aov.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/transport/interaction.h"

using namespace ptir;

namespace {

// Seconds of wall time, or of CPU time of the whole process (single-threaded runs:
// unaffected by other processes taking turns on the cores).
double now(bool cpu) {
  if (!cpu) return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Median time of `repeat` runs of fn (after one warm-up run).
double median_seconds(int repeat, bool cpu, const std::function<void()>& fn) {
  fn();
  std::vector<double> t;
  for (int i = 0; i < repeat; ++i) {
    double t0 = now(cpu);
    fn();
    t.push_back(now(cpu) - t0);
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
  std::vector<std::string> variants = {"render_aov", "aov1x1", "aov2x2", "aov4x2", "aov4x4", "trav1x1", "trav4x4"};
};

// A way to render the opacity AOV: render_aov itself (block 0x0) or the bench's
// copy of its per-pixel work over blocks of bw x bh pixels (1x1: walk per ray),
// with the full interaction (aov) or the opacity only (trav).
struct Variant {
  std::string name;
  int bw = 0, bh = 0;
  bool material = true;
};

Variant parse_variant(const std::string& s) {
  if (s == "render_aov") return {"render_aov", 0, 0, true};
  int w = 0, h = 0;
  bool aov = s.rfind("aov", 0) == 0, trav = s.rfind("trav", 0) == 0;
  if ((!aov && !trav) || std::sscanf(s.c_str() + (aov ? 3 : 4), "%dx%d", &w, &h) != 2 || w < 1 || h < 1 ||
      w * h > SceneAccel::kMaxPacket)
    throw Error("unknown variant '" + s + "' (render_aov, aovWxH or travWxH with W*H <= 16)");
  return {std::string(aov ? "aov " : "trav ") + s.substr(aov ? 3 : 4), w, h, aov};
}

// Opacity-only compositing (trav variants): the sums InteractionBuilder makes for O.
struct Opacity {
  float T = 1.0f, O = 0.0f;
  bool add(const GaussianHit& h, float min_T) {
    O += T * h.alpha;
    T *= 1.0f - h.alpha;
    return T >= min_T;
  }
};

// The opacity AOV at pixel centres, as render_aov(Aov::Opacity) computes it
// (trace_aov without preview, then the coverage), over 8x8 tiles in parallel,
// each tile in blocks of bw x bh pixels traced together (1x1: SceneAccel::walk).
// Without `material`, the hits are composited into the opacity only.
Image render_opacity_blocks(const SceneAccel& accel, const Camera& cam, int bw, int bh, bool material,
                            const AovSettings& settings, TraceStats* stats) {
  Image image(cam.width, cam.height, {"A"});
  const GaussianField& field = accel.field();
  const float min_T = accel.settings().cull.min_transmittance;
  std::atomic<uint64_t> rounds{0}, hits{0}, candidates{0}, packet_rounds{0};
  tbb::parallel_for(tbb::blocked_range2d<int>(0, cam.height, 8, 0, cam.width, 8), [&](const tbb::blocked_range2d<int>& r) {
    TraceStats local;
    for (int by = r.rows().begin(); by < r.rows().end(); by += bh)
      for (int bx = r.cols().begin(); bx < r.cols().end(); bx += bw) {
        // The block's rays and compositing, lane = row-major pixel index.
        constexpr int kMax = SceneAccel::kMaxPacket;
        Ray rays[kMax];
        InteractionBuilder* builders[kMax];
        alignas(InteractionBuilder) unsigned char storage[kMax][sizeof(InteractionBuilder)];
        Opacity opacity[kMax];
        int xs[kMax], ys[kMax], n = 0;
        for (int y = by; y < std::min(by + bh, r.rows().end()); ++y)
          for (int x = bx; x < std::min(bx + bw, r.cols().end()); ++x) {
            Rng rng(settings.seed, uint64_t(y) * uint64_t(cam.width) + uint64_t(x), 0);
            rays[n] = cam.generate_ray(float(x) + 0.5f, float(y) + 0.5f);
            if (material) builders[n] = new (storage[n]) InteractionBuilder(field, settings.interaction, min_T, rays[n].d, rng.key());
            xs[n] = x, ys[n] = y;
            n++;
          }
        auto visit = [&](int lane, const GaussianHit& h) {
          return material ? builders[lane]->add(h) : opacity[lane].add(h, min_T);
        };
        WalkEnd ends[kMax];
        if (n == 1) ends[0] = accel.walk(rays[0], [&](const GaussianHit& h) { return visit(0, h); }, &local, true);
        else accel.walk_packet(rays, n, visit, ends, &local, true);
        // Coverage as render_aov: the Gaussians' opacity, plus what a mesh behind covers.
        for (int l = 0; l < n; ++l) {
          float O = opacity[l].O, T = opacity[l].T;
          if (material) {
            SurfaceInteraction si = builders[l]->finish(rays[l]);
            O = si.opacity, T = si.transmittance;
            builders[l]->~InteractionBuilder();
          }
          image.at(xs[l], ys[l], 0) = std::min(1.0f, O + ((!ends[l].stopped && ends[l].mesh.valid) ? T : 0.0f));
        }
      }
    rounds += local.rounds, hits += local.hits, candidates += local.candidates, packet_rounds += local.packet_rounds;
  });
  stats->rounds += rounds, stats->hits += hits, stats->candidates += candidates, stats->packet_rounds += packet_rounds;
  return image;
}

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
  double secs = with_threads(threads, [&] { return median_seconds(repeat, threads == 1, trace_all); });
  return {double(rays.size()) / secs, double(hits) / double(rays.size())};
}

// Best Gaussian/triangle throughput ratio seen per thread setting, for the summary.
struct Best {
  double ratio = 0;
  std::string what;
};

int run(const Options& o) {
  double t0 = now(false);
  std::vector<Variant> variants;
  for (const std::string& v : o.variants) variants.push_back(parse_variant(v));
  GaussianField field = load_gaussians(o.gaussians);
  std::vector<Camera> cams = load_transforms_json(o.cameras, o.size, o.size);
  if (o.frame < 0 || o.frame >= int(cams.size())) throw Error(o.cameras, "frame out of range");
  Camera cam = cams[o.frame];
  cam.fov_x = 2.0f * std::atan(std::tan(0.5f * cam.fov_x) / o.zoom);
  const double n_rays = double(cam.width) * cam.height;
  std::printf("bench_trace: %zu Gaussians, %dx%d primary rays (frame %d, zoom %g), %u hardware threads, median of %d"
              " runs (loaded in %.1f s)\n",
              field.size(), cam.width, cam.height, o.frame, o.zoom, std::thread::hardware_concurrency(), o.repeat,
              now(false) - t0);

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

  std::printf("\n%4s  %-7s  %-11s  %15s  %15s  %6s  %8s  %10s  %9s  %8s\n", "k", "threads", "variant", "Gaussian rays/s",
              "triangle rays/s", "ratio", "hits/ray", "rounds/ray", "boxes/ray", "coverage");
  AovSettings settings;  // pixel centres, aggregate interaction
  Best best[4];  // [1 thread, all threads] x [with material, traversal only]
  bool render_aov_packets = false;
  for (int k : o.ks) {
    AccelSettings as;
    as.k = k;
    SceneAccel accel(field, {}, as);
    for (int threads : {1, 0}) {
      Image reference;
      for (const Variant& v : variants) {
        TraceStats stats;
        Image img;
        auto render = [&] {
          stats = TraceStats();
          img = v.bw == 0 ? render_aov(accel, cam, Aov::Opacity, settings, {}, &stats)
                          : render_opacity_blocks(accel, cam, v.bw, v.bh, v.material, settings, &stats);
        };
        double secs = with_threads(threads, [&] { return median_seconds(o.repeat, threads == 1, render); });
        if (v.bw == 0) render_aov_packets = stats.packet_rounds > 0;
        // Every variant renders the same image (the walks give identical hits).
        if (reference.pixels.empty()) reference = img;
        else if (img.pixels != reference.pixels) throw Error("variant '" + v.name + "' renders a different image");
        // Triangles right after, under the same machine load: the ratio is what counts.
        MeshResult tri = bench_triangles(tri_accel, rays, threads, o.repeat);
        double coverage = 0;
        for (float a : img.pixels) coverage += a;
        double g = n_rays / secs, t = tri.rays_per_s;
        std::printf("%4d  %-7s  %-11s  %15.0f  %15.0f  %5.1fx  %8.2f  %10.2f  %9.2f  %7.1f%%\n", k,
                    threads == 1 ? "1" : "all", v.name.c_str(), g, t, t / g, double(stats.hits) / n_rays,
                    double(stats.rounds) / n_rays, double(stats.candidates) / n_rays, 100.0 * coverage / n_rays);
        Best& b = best[(threads == 1 ? 0 : 1) + (v.material ? 0 : 2)];
        if (g / t > b.ratio) b = {g / t, v.name + ", k=" + std::to_string(k)};
      }
    }
  }
  std::printf("\nratio = triangle rays/s / Gaussian rays/s (how many times slower the Gaussians are); hits: Gaussians\n"
              "composited; boxes: Gaussians tested per ray (packets: every lane tested counts)\n"
              "aov: render_aov's per-pixel work (InteractionBuilder: depth, normal, material sums); trav: the traversal\n"
              "alone (hits in order, composited into opacity only, like a closest hit that fetches nothing)\n\n");
  for (int i = 0; i < 4; ++i) {
    if (best[i].what.empty()) continue;
    std::printf("best Gaussian/triangle throughput, %-9s %-13s %.2f (1/%.1f) with %s; >= 1/3: %s\n",
                i % 2 == 0 ? "1 thread," : "all,", i < 2 ? "full AOV:" : "traversal:", best[i].ratio,
                1.0 / best[i].ratio, best[i].what.c_str(), best[i].ratio >= 1.0 / 3.0 ? "yes" : "NO");
  }
  std::printf("render_aov traces %s\n", render_aov_packets ? "packets (SceneAccel::walk_packet)"
                                                           : "one ray at a time (SceneAccel::walk)");
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
  app.add_option("--variants", o.variants, "render_aov, aovWxH (its work in WxH blocks), travWxH (traversal only)")
      ->capture_default_str();
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
