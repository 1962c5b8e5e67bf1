#include "ptir/eval/relight.h"


#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/render/render_path.h"

namespace ptir::eval {

Image render_transparent(const PathTracer& tracer, const Camera& camera, const IntegratorSettings& settings,
                         const RenderControl& control, PathStats* stats) {
  return render_path(tracer, camera, settings, control, stats, nullptr, /*transparent_film=*/true);
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
