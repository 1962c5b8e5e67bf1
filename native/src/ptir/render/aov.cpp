#include "ptir/render/aov.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <mutex>
#include <optional>

#include "ptir/core/error.h"
#include "ptir/math/path_sampler.h"
#include "ptir/scene/mesh_surface.h"

namespace ptir {

Aov parse_aov(const std::string& name) {
  static const std::pair<const char*, Aov> table[] = {
      {"opacity", Aov::Opacity}, {"depth", Aov::Depth},       {"normal", Aov::Normal},   {"albedo", Aov::Albedo},
      {"roughness", Aov::Roughness}, {"metallic", Aov::Metallic}, {"preview", Aov::Preview},
      {"diffuse_color", Aov::DiffuseColor}};
  for (const auto& [n, a] : table)
    if (name == n) return a;
  throw Error("unknown AOV '" + name + "' (choose opacity, depth, normal, albedo, diffuse_color, roughness, metallic or preview)");
}

const char* aov_name(Aov aov) {
  switch (aov) {
    case Aov::Opacity: return "opacity";
    case Aov::Depth: return "depth";
    case Aov::Normal: return "normal";
    case Aov::Albedo: return "albedo";
    case Aov::Roughness: return "roughness";
    case Aov::Metallic: return "metallic";
    case Aov::Preview: return "preview";
    case Aov::DiffuseColor: return "diffuse_color";
  }
  return "?";
}

Encoding aov_encoding(Aov aov) {
  if (aov == Aov::Preview) return Encoding::Colour;  // associated, as path-traced colour
  return (aov == Aov::Albedo || aov == Aov::DiffuseColor) ? Encoding::StraightColour : Encoding::Data;
}

namespace {

// The AOV sample of a ray from its interaction and how its walk ended.
AovSample aov_sample(const SceneAccel& accel, const Ray& ray, const SurfaceInteraction& si, const WalkEnd& end,
                     Vec3 preview) {
  AovSample s;
  float T = si.transmittance;
  s.opacity = si.opacity;
  s.preview = preview;
  if (si.valid) {
    s.hit = true;
    s.depth = si.depth;
    s.normal = si.n;
    s.albedo = si.albedo;
    s.roughness = si.roughness;
    s.metallic = si.metallic;
  }
  // An opaque mesh behind the Gaussians covers what they let through.
  if (!end.stopped && end.mesh.valid) {
    const TriangleMesh& mesh = accel.meshes()[end.mesh.mesh];
    Vec3 ng = mesh.face_normal(end.mesh.prim);
    if (dot(ng, ray.d) > 0.0f) ng = -ng;
    s.opacity += T;
    // Preview shades the mesh by its base colour under a headlight (display space).
    const Vec3 base_colour = mesh_base_colour(mesh, end.mesh.prim, end.mesh.u, end.mesh.v);
    Vec3 shaded = base_colour * std::fabs(dot(ng, ray.d));
    s.preview += T * Vec3(linear_to_srgb(shaded.x), linear_to_srgb(shaded.y), linear_to_srgb(shaded.z));
    if (!si.valid) {
      s.hit = true;
      s.depth = end.mesh.t;
      s.normal = ng;
      s.albedo = base_colour;
      s.roughness = mesh.material.roughness;
      s.metallic = mesh.material.metallic;
    }
  }
  return s;
}

}  // namespace

AovSample trace_aov(const SceneAccel& accel, const Ray& ray, const AovSettings& settings, uint64_t pick_key,
                    bool with_preview, TraceStats* stats, AovWalk* walk) {
  const GaussianField& field = accel.field();
  InteractionBuilder builder(field, settings.interaction, accel.settings().cull.min_transmittance, ray.d, pick_key);
  Vec3 preview;
  if (walk) walk->hits.clear();
  // Walk the Gaussians front to back: interaction sums and SH colour together.
  WalkEnd end = accel.walk(
      ray,
      [&](const GaussianHit& h) {
        if (with_preview) preview += (builder.transmittance() * h.alpha) * field.sh_colour(h.id, ray.d);
        if (walk) walk->hits.push_back(h);
        return builder.add(h);
      },
      stats, /*stop_when_opaque=*/true);
  if (walk) walk->end = end;
  return aov_sample(accel, ray, builder.finish(ray), end, preview);
}

void trace_aov_packet(const SceneAccel& accel, const Ray* rays, int n, const AovSettings& settings,
                      const uint64_t* pick_keys, bool with_preview, AovSample* samples, TraceStats* stats,
                      AovWalk* walks) {
  const GaussianField& field = accel.field();
  const float min_T = accel.settings().cull.min_transmittance;
  std::optional<InteractionBuilder> builders[SceneAccel::kMaxPacket];
  Vec3 preview[SceneAccel::kMaxPacket];
  for (int l = 0; l < n; ++l) builders[l].emplace(field, settings.interaction, min_T, rays[l].d, pick_keys[l]);
  if (walks)
    for (int l = 0; l < n; ++l) walks[l].hits.clear();
  // The same walk per lane as trace_aov, the rays traced together.
  WalkEnd ends[SceneAccel::kMaxPacket];
  accel.walk_packet(
      rays, n,
      [&](int l, const GaussianHit& h) {
        if (with_preview) preview[l] += (builders[l]->transmittance() * h.alpha) * field.sh_colour(h.id, rays[l].d);
        if (walks) walks[l].hits.push_back(h);
        return builders[l]->add(h);
      },
      ends, stats, /*stop_when_opaque=*/true);
  if (walks)
    for (int l = 0; l < n; ++l) walks[l].end = ends[l];
  for (int l = 0; l < n; ++l) samples[l] = aov_sample(accel, rays[l], builders[l]->finish(rays[l]), ends[l], preview[l]);
}

namespace {

std::vector<std::string> aov_channels(Aov aov) {
  switch (aov) {
    case Aov::Opacity: return {"A"};
    case Aov::Depth: return {"Z", "A"};
    case Aov::Normal: return {"X", "Y", "Z", "A"};
    case Aov::Roughness:
    case Aov::Metallic: return {"Y", "A"};
    default: return {"R", "G", "B", "A"};
  }
}

// Channel values of one sample (without alpha, which is the mean coverage).
void aov_values(Aov aov, const AovSample& s, float* v) {
  switch (aov) {
    case Aov::Opacity: break;
    case Aov::Depth: v[0] = s.hit ? s.depth : 0.0f; break;
    case Aov::Normal: v[0] = s.normal.x; v[1] = s.normal.y; v[2] = s.normal.z; break;
    case Aov::Albedo: v[0] = s.albedo.x; v[1] = s.albedo.y; v[2] = s.albedo.z; break;
    case Aov::DiffuseColor: {
      const Vec3 d = s.albedo * (1.0f - s.metallic);  // the diffuse closure's weight (Principled, simplified Disney)
      v[0] = d.x, v[1] = d.y, v[2] = d.z;
      break;
    }
    case Aov::Roughness: v[0] = s.roughness; break;
    case Aov::Metallic: v[0] = s.metallic; break;
    case Aov::Preview: v[0] = s.preview.x; v[1] = s.preview.y; v[2] = s.preview.z; break;
  }
}

}  // namespace

Image render_aov(const SceneAccel& accel, const Camera& camera, Aov aov, const AovSettings& settings,
                 const RenderControl& control, TraceStats* stats) {
  if (settings.spp < 1) throw Error("samples per pixel must be at least 1");
  const PixelFilterSampler filter(settings.filter);
  Image image(camera.width, camera.height, aov_channels(aov));
  const int nc = image.channels;
  const int spp = settings.spp;
  std::atomic<int> rows_done{0};
  std::atomic<uint64_t> rounds{0}, hits{0}, candidates{0}, packet_rounds{0};
  std::mutex progress_mutex;

  tbb::parallel_for(tbb::blocked_range2d<int>(0, camera.height, 8, 0, camera.width, 8), [&](const tbb::blocked_range2d<int>& r) {
    if (control.cancel && control.cancel->load()) return;
    TraceStats local;
    // Blocks of 4x4 pixels: their rays (sample s of each pixel) are traced together.
    constexpr int kBlock = 4, kLanes = kBlock * kBlock;
    for (int by = r.rows().begin(); by < r.rows().end(); by += kBlock)
      for (int bx = r.cols().begin(); bx < r.cols().end(); bx += kBlock) {
        int xs[kLanes], ys[kLanes], n = 0;
        for (int y = by; y < std::min(by + kBlock, r.rows().end()); ++y)
          for (int x = bx; x < std::min(bx + kBlock, r.cols().end()); ++x) xs[n] = x, ys[n] = y, n++;
        float acc[kLanes][4] = {}, coverage[kLanes] = {};
        for (int s = 0; s < spp; ++s) {
          // One sample at the pixel centre, or samples offset by the pixel filter with
          // numbers keyed on (seed, pixel, sample) and stratified over the pixel's
          // samples, weight 1 each (as render_path); `rng` keys the discrete picks.
          Ray rays[kLanes];
          uint64_t keys[kLanes];
          for (int l = 0; l < n; ++l) {
            const uint64_t pixel = camera.full_pixel_index(xs[l], ys[l]);
            Rng rng(settings.seed, pixel, uint64_t(s));
            PathRng offset(make_path_key(settings.seed, pixel, uint32_t(s)), ~uint64_t(0), 0);
            float px = spp == 1 ? float(xs[l]) + 0.5f : filter.position(xs[l], offset.at(0));
            float py = spp == 1 ? float(ys[l]) + 0.5f : filter.position(ys[l], offset.at(1));
            rays[l] = camera.generate_ray(px, py);
            keys[l] = rng.key();
          }
          AovSample smp[kLanes];
          trace_aov_packet(accel, rays, n, settings, keys, aov == Aov::Preview, smp, &local);
          for (int l = 0; l < n; ++l) {
            float v[4] = {0, 0, 0, 0};
            aov_values(aov, smp[l], v);
            // Data channels are averaged over covered samples; colour is premultiplied.
            float weight = (aov == Aov::Preview) ? 1.0f : (smp[l].hit ? 1.0f : 0.0f);
            for (int c = 0; c < nc - 1; ++c) acc[l][c] += weight * v[c];
            acc[l][3] += weight;
            coverage[l] += std::min(1.0f, smp[l].opacity);
          }
        }
        for (int l = 0; l < n; ++l) {
          const int x = xs[l], y = ys[l];
          float norm = aov == Aov::Preview ? 1.0f / float(spp) : (acc[l][3] > 0 ? 1.0f / acc[l][3] : 0.0f);
          for (int c = 0; c < nc - 1; ++c) image.at(x, y, c) = acc[l][c] * norm;
          // Preview: the display-space composite (SH colours are display values, blended
          // as a 3DGS rasteriser blends them) as linear colour associated with the
          // coverage: un-premultiplied in display space, decoded, premultiplied again.
          if (aov == Aov::Preview) {
            const float a = std::clamp(coverage[l] / float(spp), 0.0f, 1.0f);
            for (int c = 0; c < 3; ++c) {
              const float straight = a > 1e-6f ? std::min(1.0f, image.at(x, y, c) / a) : 0.0f;
              image.at(x, y, c) = a * srgb_to_linear(straight);
            }
          }
          // Normals averaged over samples are renormalised.
          if (aov == Aov::Normal && acc[l][3] > 0) {
            Vec3 nrm = normalize(Vec3(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2)));
            for (int c = 0; c < 3; ++c) image.at(x, y, c) = nrm[c];
          }
          image.at(x, y, nc - 1) = coverage[l] / float(spp);
        }
      }
    rounds += local.rounds;
    hits += local.hits;
    candidates += local.candidates;
    packet_rounds += local.packet_rounds;
    int done = rows_done.fetch_add(int(r.rows().size() * r.cols().size()));
    if (control.progress) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      control.progress(float(done + r.rows().size() * r.cols().size()) / float(camera.width * camera.height));
    }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
  if (stats) {
    stats->rounds += rounds;
    stats->hits += hits;
    stats->candidates += candidates;
    stats->packet_rounds += packet_rounds;
  }
  return image;
}


Image aov_for_8bit(Aov aov, const Image& image, float* depth_scale) {
  Image out = image;
  const int nc = image.channels;
  if (aov == Aov::Normal) {
    for (size_t p = 0; p < size_t(image.width) * image.height; ++p)
      for (int c = 0; c < 3; ++c) out.pixels[p * nc + c] = 0.5f + 0.5f * image.pixels[p * nc + c];
  } else if (aov == Aov::Depth) {
    float max_depth = 0.0f;
    for (size_t p = 0; p < size_t(image.width) * image.height; ++p) max_depth = std::max(max_depth, image.pixels[p * nc]);
    float scale = max_depth > 0.0f ? 1.0f / max_depth : 1.0f;
    for (size_t p = 0; p < size_t(image.width) * image.height; ++p) out.pixels[p * nc] *= scale;
    if (depth_scale) *depth_scale = max_depth;
  }
  return out;
}

}  // namespace ptir
