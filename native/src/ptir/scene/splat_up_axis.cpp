// The up axis of a splat PLY (splat_up_axis.h).
#include "ptir/scene/splat_up_axis.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "ptir/core/error.h"

namespace ptir {

namespace {

constexpr float kMinOpacity = 0.1f;        // fainter splats carry little fitted radiance
constexpr size_t kMaxSplats = 20000;       // the SH cue looks at an even subset of at most this many
constexpr int kDirections = 500;           // Fibonacci directions for the energy's first moment
constexpr float kAxisClarity = 0.25f;      // 1 - lambda_min / lambda_mid at least this
constexpr float kSignClarity = 0.05f;      // |energy-weighted mean of d . axis| at least this
constexpr float kCameraAgreement = 0.5f;   // |mean camera up| at least this

// Eigenvector of the smallest eigenvalue of a symmetric 3x3 matrix (cyclic
// Jacobi rotations), with the eigenvalues ascending in *lambda.
Vec3 smallest_eigenvector(double a[3][3], double lambda[3]) {
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int sweep = 0; sweep < 50; ++sweep) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    if (off < 1e-30 * (a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2]) + 1e-300) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0) continue;
        // The rotation that zeroes a[p][q].
        const double theta = 0.5 * std::atan2(2 * a[p][q], a[q][q] - a[p][p]);
        const double c = std::cos(theta), s = std::sin(theta);
        for (int k = 0; k < 3; ++k) {  // a <- a J
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq, a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // a <- J^T a
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk, a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {  // v <- v J
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq, v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int i, int j) { return a[i][i] < a[j][j]; });
  for (int i = 0; i < 3; ++i) lambda[i] = a[order[i]][order[i]];
  const int m = order[0];
  return normalize(Vec3(float(v[0][m]), float(v[1][m]), float(v[2][m])));
}

// Direction k of n, spread evenly over the sphere (Fibonacci spiral).
Vec3 fibonacci_direction(int k, int n) {
  const float z = 1.0f - 2.0f * (float(k) + 0.5f) / float(n), r = std::sqrt(std::max(0.0f, 1.0f - z * z));
  const float phi = 3.14159265358979f * (3.0f - std::sqrt(5.0f)) * float(k);
  return {r * std::cos(phi), r * std::sin(phi), z};
}

bool has_ptir_materials(const GaussianField& field) {
  const io::PlyElement* v = field.source.get("vertex");
  return v != nullptr && v->find("albedo_0") >= 0;
}

}  // namespace

Vec3 parse_up_axis(const std::string& text) {
  static const struct { const char* name; Vec3 v; } kAxes[] = {
      {"x", {1, 0, 0}}, {"y", {0, 1, 0}}, {"z", {0, 0, 1}}, {"-x", {-1, 0, 0}}, {"-y", {0, -1, 0}}, {"-z", {0, 0, -1}},
      {"+x", {1, 0, 0}}, {"+y", {0, 1, 0}}, {"+z", {0, 0, 1}}};
  std::string t;
  for (char c : text)
    if (c != ' ') t += char(std::tolower(static_cast<unsigned char>(c)));
  for (const auto& a : kAxes)
    if (t == a.name) return a.v;
  float x, y, z;
  char tail;
  if (std::sscanf(t.c_str(), "%f,%f,%f%c", &x, &y, &z, &tail) == 3) {
    const Vec3 v(x, y, z);
    if (is_finite(v) && length(v) > 1e-6f) return normalize(v);
  }
  throw Error("--up '" + text + "': give x, y, z, -x, -y, -z or a non-zero vector X,Y,Z");
}

UpCue up_from_cameras(const std::vector<Camera>& cameras) {
  UpCue cue;
  if (cameras.empty()) {
    cue.note = "no --cameras";
    return cue;
  }
  cue.available = true;
  Vec3 sum(0, 0, 0);
  for (const Camera& c : cameras) sum = sum + normalize(c.cam_to_world.linear.col(1));  // the camera's +y: its up
  const float agreement = length(sum) / float(cameras.size());
  cue.axis_clarity = agreement;
  if (agreement > 0) cue.up = normalize(sum);
  cue.clear = agreement >= kCameraAgreement;
  if (!cue.clear) cue.note = "the cameras' up vectors disagree";
  return cue;
}

UpCue up_from_sh(const GaussianField& field) {
  UpCue cue;
  if (field.sh_degree < 1) {
    cue.note = "no view-dependent SH (degree 0)";
    return cue;
  }
  std::vector<size_t> kept;
  for (size_t i = 0; i < field.size(); ++i)
    if (field.opacity[i] >= kMinOpacity) kept.push_back(i);
  const size_t stride = std::max<size_t>(1, kept.size() / kMaxSplats);
  const int stride_sh = field.sh_stride(), nk = (field.sh_degree + 1) * (field.sh_degree + 1);
  // Degree 1: colour_c(d) - DC = C1 (-y k1 + z k2 - x k3) = b_c . d with b_c = C1 (-k3, -k1, k2).
  double m[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  for (size_t j = 0; j < kept.size(); j += stride) {
    const size_t i = kept[j];
    const float* s = &field.sh[i * stride_sh];
    for (int c = 0; c < 3; ++c) {
      const double b[3] = {-s[3 * 3 + c], -s[1 * 3 + c], s[2 * 3 + c]};
      for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) m[r][q] += field.opacity[i] * b[r] * b[q];
    }
  }
  double lambda[3];
  const Vec3 axis = smallest_eigenvector(m, lambda);
  cue.available = true;
  cue.axis_clarity = lambda[1] > 0 ? float(1.0 - lambda[0] / lambda[1]) : 0.0f;
  // The first moment of the view-dependent energy over the sphere, along the axis.
  double energy = 0, moment = 0;
  float y[kMaxShCoefficients];
  for (int k = 0; k < kDirections; ++k) {
    const Vec3 d = fibonacci_direction(k, kDirections);
    sh_basis(field.sh_degree, d, y);
    double e = 0;
    for (size_t j = 0; j < kept.size(); j += stride) {
      const size_t i = kept[j];
      const float* s = &field.sh[i * stride_sh];
      double v[3] = {0, 0, 0};
      for (int b = 1; b < nk; ++b)
        for (int c = 0; c < 3; ++c) v[c] += y[b] * s[b * 3 + c];
      e += field.opacity[i] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    }
    energy += e;
    moment += e * dot(d, axis);
  }
  const float mean = energy > 0 ? float(moment / energy) : 0.0f;
  cue.sign_clarity = std::fabs(mean);
  cue.up = mean > 0 ? -axis : axis;  // the seen directions (more energy) point from the cameras down
  cue.clear = cue.axis_clarity >= kAxisClarity && cue.sign_clarity >= kSignClarity;
  if (!cue.clear)
    cue.note = cue.axis_clarity < kAxisClarity ? "no clear axis in the degree-1 SH" : "no clear hemisphere in the SH energy";
  return cue;
}

UpAxis decide_up_axis(const GaussianField& field, const std::string& flag, const std::vector<Camera>& cameras) {
  UpAxis r;
  r.cameras = up_from_cameras(cameras);
  r.sh = up_from_sh(field);
  if (!flag.empty()) {
    r.up = parse_up_axis(flag), r.source = "flag";
  } else if (r.cameras.clear) {
    r.up = r.cameras.up, r.source = "cameras";
  } else if (r.sh.clear) {
    r.up = r.sh.up, r.source = "sh";
  } else if (has_ptir_materials(field)) {
    r.up = Vec3(0, 0, 1), r.source = "ptir file";
  } else {
    r.up = Vec3(0, -1, 0), r.source = "trainer convention";
  }
  return r;
}

std::string up_axis_json(const UpAxis& u) {
  const auto v3 = [](Vec3 v) { return nlohmann::json::array({v.x, v.y, v.z}); };
  const auto cue = [&](const UpCue& c, const char* a, const char* b) {
    nlohmann::json j = {{"available", c.available}, {"clear", c.clear}};
    if (c.available) j["up"] = v3(c.up), j[a] = c.axis_clarity;
    if (c.available && b) j[b] = c.sign_clarity;
    if (!c.note.empty()) j["note"] = c.note;
    return j;
  };
  nlohmann::json j = {{"up", v3(u.up)}, {"source", u.source},
                      {"cues", {{"cameras", cue(u.cameras, "agreement", nullptr)},
                                {"sh", cue(u.sh, "axis_clarity", "sign_clarity")}}}};
  return j.dump();
}

std::string with_up_axis(const std::string& views_json, const UpAxis& up) {
  nlohmann::json j = nlohmann::json::parse(views_json);
  j["up_axis"] = nlohmann::json::parse(up_axis_json(up));
  return j.dump(1);
}

}  // namespace ptir
