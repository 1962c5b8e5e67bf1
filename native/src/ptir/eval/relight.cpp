#include "ptir/eval/relight.h"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <sstream>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/math/rng.h"

namespace ptir::eval {

Image render_transparent(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                         const RenderControl& control, PathStats* stats) {
  if (settings.spp < 1) throw Error("samples per pixel must be at least 1");
  if (settings.max_bounces < 0) throw Error("bounces must be at least 0");
  Image image(camera.width, camera.height, {"R", "G", "B", "A"});
  const size_t pixels = size_t(camera.width) * size_t(camera.height);
  std::atomic<size_t> done{0};
  std::atomic<uint64_t> paths{0}, vertices{0}, shadow_rays{0};
  std::mutex progress_mutex;
  tbb::parallel_for(tbb::blocked_range2d<int>(0, camera.height, 8, 0, camera.width, 8), [&](const tbb::blocked_range2d<int>& r) {
    if (control.cancel && control.cancel->load()) return;
    PathStats local;
    for (int y = r.rows().begin(); y < r.rows().end(); ++y)
      for (int x = r.cols().begin(); x < r.cols().end(); ++x) {
        Vec3 sum(0.0f);
        float covered = 0.0f;
        const uint64_t pixel = camera.full_pixel_index(x, y);
        for (int s = 0; s < settings.spp; ++s) {
          // Same jitter keys as render_path's camera_sample.
          Rng jitter(hash_combine(hash_combine(settings.seed, pixel), uint64_t(s)), 0, 0);
          Ray ray = camera.generate_ray(float(x) + jitter.at(0), float(y) + jitter.at(1));
          float c = 0.0f;
          Vec3 L = tracer.sample_radiance(ray, pixel, uint32_t(s), settings, &c, &local);
          if (c > 0.0f) {
            sum += L;
            covered += 1.0f;
          }
        }
        const float inv = 1.0f / float(settings.spp);
        image.at(x, y, 0) = sum.x * inv;
        image.at(x, y, 1) = sum.y * inv;
        image.at(x, y, 2) = sum.z * inv;
        image.at(x, y, 3) = covered * inv;
      }
    paths += local.paths;
    vertices += local.vertices;
    shadow_rays += local.shadow_rays;
    size_t n = r.rows().size() * r.cols().size();
    size_t now = done.fetch_add(n) + n;
    if (control.progress) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      control.progress(float(now) / float(pixels));
    }
  });
  if (control.cancel && control.cancel->load()) throw Cancelled();
  if (stats) {
    stats->paths += paths;
    stats->vertices += vertices;
    stats->shadow_rays += shadow_rays;
  }
  return image;
}

void scale_albedo(GaussianField& field, const std::array<double, 3>& s) {
  for (Vec3& a : field.albedo)
    for (int c = 0; c < 3; ++c) a[c] = float(std::clamp(double(a[c]) * s[c], 0.0, 1.0));
}

namespace {

std::vector<float> parse_numbers(const std::string& spec, const char* what) {
  std::string t = spec;
  for (char& ch : t)
    if (ch == ',') ch = ' ';
  std::istringstream in(t);
  std::vector<float> v;
  std::string tok;
  while (in >> tok) {
    try {
      size_t used = 0;
      float f = std::stof(tok, &used);
      if (used != tok.size() || !std::isfinite(f)) throw std::invalid_argument(tok);
      v.push_back(f);
    } catch (const std::exception&) {
      throw Error(std::string(what) + " '" + spec + "': '" + tok + "' is not a number");
    }
  }
  return v;
}

}  // namespace

PointLight parse_point_light(const std::string& spec) {
  std::vector<float> v = parse_numbers(spec, "--point");
  if (v.size() != 4 && v.size() != 7 && v.size() != 8)
    throw Error("--point '" + spec + "': expected x,y,z,watts[,r,g,b[,radius]]");
  Vec3 colour = v.size() >= 7 ? Vec3(v[4], v[5], v[6]) : Vec3(1.0f);
  float radius = v.size() == 8 ? v[7] : 0.0f;
  if (v[3] < 0 || radius < 0 || colour.x < 0 || colour.y < 0 || colour.z < 0)
    throw Error("--point '" + spec + "': power, colour and radius must be >= 0");
  return PointLight::from_blender(Vec3(v[0], v[1], v[2]), v[3], colour, radius);
}

AreaLight parse_area_light(const std::string& spec) {
  std::vector<float> v = parse_numbers(spec, "--area");
  if (v.size() != 9 && v.size() != 12)
    throw Error("--area '" + spec + "': expected cx,cy,cz,tx,ty,tz,size_x,size_y,watts[,r,g,b]");
  Vec3 c(v[0], v[1], v[2]), t(v[3], v[4], v[5]);
  Vec3 colour = v.size() == 12 ? Vec3(v[9], v[10], v[11]) : Vec3(1.0f);
  if (!(v[6] > 0) || !(v[7] > 0) || v[8] < 0) throw Error("--area '" + spec + "': sizes must be > 0 and power >= 0");
  Vec3 d = t - c;
  if (length(d) < 1e-6f) throw Error("--area '" + spec + "': the target coincides with the centre");
  Vec3 emit = normalize(d);          // the light emits along its local -z
  Vec3 z = -emit;                    // local +z
  Vec3 x = cross(Vec3(0, 0, 1), z);  // horizontal local x
  if (length(x) < 1e-4f) x = Vec3(1, 0, 0);  // facing straight up/down
  x = normalize(x);
  Vec3 y = cross(z, x);
  Affine m;
  m.linear = Mat3::from_cols(x, y, z);
  m.translation = c;
  return AreaLight::from_blender(m, AreaShape::Rectangle, v[6], v[7], v[8], colour);
}

}  // namespace ptir::eval
