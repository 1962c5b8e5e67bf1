// Scene files (docs/scene_format.md): JSON -> Scene, with strict key checking
// and messages that name the file and the JSON path of the offending value.
#include "ptir/scene/scene_json.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/io/input_file.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/json_limits.h"
#include "ptir/scene/json_node.h"
#include "ptir/scene/material_json.h"
#include "ptir/scene/mesh_tangents.h"

namespace ptir {

namespace fs = std::filesystem;
using json = nlohmann::json;

// ---------------------------------------------------------------------------
// Gaussian transforms

std::array<float, 4> mat3_to_quat(const Mat3& r) {
  // Shepperd's method: build from the largest of (w, x, y, z) for accuracy.
  const double m00 = r.m[0][0], m11 = r.m[1][1], m22 = r.m[2][2];
  const double tr = m00 + m11 + m22;
  double q[4];
  if (tr >= m00 && tr >= m11 && tr >= m22) {
    double s = 2.0 * std::sqrt(std::max(1e-30, 1.0 + tr));
    q[0] = 0.25 * s;
    q[1] = (r.m[2][1] - r.m[1][2]) / s;
    q[2] = (r.m[0][2] - r.m[2][0]) / s;
    q[3] = (r.m[1][0] - r.m[0][1]) / s;
  } else if (m00 >= m11 && m00 >= m22) {
    double s = 2.0 * std::sqrt(std::max(1e-30, 1.0 + m00 - m11 - m22));
    q[0] = (r.m[2][1] - r.m[1][2]) / s;
    q[1] = 0.25 * s;
    q[2] = (r.m[0][1] + r.m[1][0]) / s;
    q[3] = (r.m[0][2] + r.m[2][0]) / s;
  } else if (m11 >= m22) {
    double s = 2.0 * std::sqrt(std::max(1e-30, 1.0 + m11 - m00 - m22));
    q[0] = (r.m[0][2] - r.m[2][0]) / s;
    q[1] = (r.m[0][1] + r.m[1][0]) / s;
    q[2] = 0.25 * s;
    q[3] = (r.m[1][2] + r.m[2][1]) / s;
  } else {
    double s = 2.0 * std::sqrt(std::max(1e-30, 1.0 + m22 - m00 - m11));
    q[0] = (r.m[1][0] - r.m[0][1]) / s;
    q[1] = (r.m[0][2] + r.m[2][0]) / s;
    q[2] = (r.m[1][2] + r.m[2][1]) / s;
    q[3] = 0.25 * s;
  }
  double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  double sign = q[0] < 0.0 ? -1.0 : 1.0;
  return {float(sign * q[0] / n), float(sign * q[1] / n), float(sign * q[2] / n), float(sign * q[3] / n)};
}

namespace {

// Splits the linear part of an affine transform into s * Q (Q orthogonal, s > 0);
// throws when it is not a similarity.
void similarity_parts(const Mat3& a, const std::string& what, float* scale, Mat3* q, bool* mirror) {
  double ata[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += double(a.m[k][i]) * a.m[k][j];
      ata[i][j] = s;
    }
  double s2 = (ata[0][0] + ata[1][1] + ata[2][2]) / 3.0;
  if (!(s2 > 1e-24) || !std::isfinite(s2)) throw Error(what, "transform is degenerate (zero or non-finite linear part)");
  double worst = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) worst = std::max(worst, std::fabs(ata[i][j] / s2 - (i == j ? 1.0 : 0.0)));
  if (worst > 2e-4) {
    double sx = std::sqrt(ata[0][0]), sy = std::sqrt(ata[1][1]), sz = std::sqrt(ata[2][2]);
    std::ostringstream msg;
    msg << "transform has a non-uniform scale or shear (column lengths " << sx << ", " << sy << ", " << sz
        << "); Gaussians support rotation, translation and uniform scale only";
    throw Error(what, msg.str());
  }
  double s = std::sqrt(s2);
  *scale = float(s);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) q->m[i][j] = float(a.m[i][j] / s);
  double det = double(q->m[0][0]) * (double(q->m[1][1]) * q->m[2][2] - double(q->m[1][2]) * q->m[2][1]) -
               double(q->m[0][1]) * (double(q->m[1][0]) * q->m[2][2] - double(q->m[1][2]) * q->m[2][0]) +
               double(q->m[0][2]) * (double(q->m[1][0]) * q->m[2][1] - double(q->m[1][1]) * q->m[2][0]);
  *mirror = det < 0.0;
}

Affine affine_from_rowmajor(const float m[16]) {
  Affine a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a.linear.m[r][c] = m[r * 4 + c];
  a.translation = Vec3(m[3], m[7], m[11]);
  return a;
}

}  // namespace

void transform_gaussians(GaussianField& field, const float m[16], const std::string& what) {
  for (int i = 0; i < 16; ++i)
    if (!std::isfinite(m[i])) throw Error(what, "transform has a non-finite entry");
  if (m[12] != 0.0f || m[13] != 0.0f || m[14] != 0.0f || m[15] != 1.0f)
    throw Error(what, "transform must be affine (last row 0 0 0 1)");
  Affine a = affine_from_rowmajor(m);
  float s;
  Mat3 q;
  bool mirror;
  similarity_parts(a.linear, what, &s, &q, &mirror);
  // A mirror Q (det -1): Sigma' = Q R S^2 R^T Q^T = (Q R D) S^2 (Q R D)^T with D = diag(-1, 1, 1),
  // and Q R D is a proper rotation.
  Mat3 D;
  D.m[0][0] = mirror ? -1.0f : 1.0f;
  const size_t n = field.size();
  for (size_t i = 0; i < n; ++i) {
    field.position[i] = a.point(field.position[i]);
    field.scale[i] = field.scale[i] * s;
    Mat3 r = q * field.rotation_matrix(i) * D;
    field.rotation[i] = mat3_to_quat(r);
    if (i < field.normal.size()) field.normal[i] = normalize(q * field.normal[i]);
  }
  field.source = io::PlyFile();
}

void append_gaussians(GaussianField& a, GaussianField&& b) {
  if (a.size() == 0) {
    bool from_file = b.normals_from_file;
    a = std::move(b);
    a.normals_from_file = from_file;
    return;
  }
  if (b.size() == 0) return;
  const size_t na = a.size(), nb = b.size();
  const int degree = std::max(a.sh_degree, b.sh_degree);
  const int stride = (degree + 1) * (degree + 1) * 3;
  auto padded = [&](const GaussianField& f, size_t n) {
    std::vector<float> out(n * size_t(stride), 0.0f);
    const int fs_ = f.sh_stride();
    if (f.sh.size() == n * size_t(fs_))
      for (size_t i = 0; i < n; ++i) std::copy(f.sh.begin() + i * fs_, f.sh.begin() + (i + 1) * fs_, out.begin() + i * stride);
    return out;
  };
  std::vector<float> sh = padded(a, na);
  std::vector<float> shb = padded(b, nb);
  sh.insert(sh.end(), shb.begin(), shb.end());
  auto cat = [](auto& x, auto& y) { x.insert(x.end(), y.begin(), y.end()); };
  cat(a.position, b.position);
  cat(a.scale, b.scale);
  cat(a.rotation, b.rotation);
  cat(a.opacity, b.opacity);
  cat(a.normal, b.normal);
  cat(a.albedo, b.albedo);
  cat(a.roughness, b.roughness);
  cat(a.metallic, b.metallic);
  // Fixed Principled inputs: stored only when some field has them (defaults fill the rest).
  auto cat_optional = [&](std::vector<float>& x, std::vector<float>& y, float fallback) {
    if (x.empty() && y.empty()) return;
    x.resize(na, fallback);
    y.resize(nb, fallback);
    cat(x, y);
  };
  cat_optional(a.specular, b.specular, kDefaultSpecular);
  cat_optional(a.specular_tint, b.specular_tint, kDefaultSpecularTint);
  a.sh = std::move(sh);
  a.sh_degree = degree;
  a.normals_from_file = a.normals_from_file && b.normals_from_file;
  a.source = io::PlyFile();
  a.source_path.clear();
}

using namespace json_node;  // Ctx, Node, with_context: JSON reading with paths in messages

namespace {

// ---------------------------------------------------------------------------
// Sections

TriangleMesh parse_mesh(const Node& n, size_t index, TextureCache& textures) {
  n.check_keys({"name", "file", "vertices", "triangles", "normals", "uvs", "tangents", "transform", "material"});
  TriangleMesh mesh;
  const bool has_file = n.has("file"), has_inline = n.has("vertices") || n.has("triangles");
  if (has_file == has_inline) n.fail("needs either \"file\" or inline \"vertices\" and \"triangles\" (not both)");
  for (const char* key : {"normals", "uvs", "tangents"})
    if (has_file && n.has(key)) n[key].fail("belongs to inline meshes (a file carries its own vertex properties)");
  if (has_file) {
    std::string path = n.file("file");
    mesh = with_context(n["file"], [&] { return load_mesh(path); });
    if (mesh.name.empty()) mesh.name = fs::path(path).stem().string();
  } else {
    n.require("vertices");
    n.require("triangles");
    Node v = n["vertices"], t = n["triangles"];
    v.expect_array();
    t.expect_array();
    for (size_t i = 0; i < v.j.size(); ++i) mesh.vertices.push_back(v.at(i).vec3());
    for (size_t i = 0; i < t.j.size(); ++i) {
      Node tri = t.at(i);
      if (!tri.j.is_array() || tri.j.size() != 3) tri.fail("must be a list of 3 vertex indices");
      std::array<uint32_t, 3> idx;
      for (size_t k = 0; k < 3; ++k) {
        Node e = tri.at(k);
        int64_t x = e.integer();
        if (x < 0 || x >= int64_t(mesh.vertices.size()))
          e.fail("is out of range (the mesh has " + std::to_string(mesh.vertices.size()) + " vertices)");
        idx[k] = uint32_t(x);
      }
      mesh.triangles.push_back(idx);
    }
    if (mesh.triangles.empty()) t.fail("must hold at least one triangle");
    if (n.has("normals")) {  // shading normals, one per vertex
      Node nn = n["normals"];
      nn.expect_array();
      if (nn.j.size() != mesh.vertices.size()) nn.fail("must hold one normal per vertex");
      for (size_t i = 0; i < nn.j.size(); ++i) {
        const Vec3 v = nn.at(i).vec3();
        if (!is_finite(v) || !(length_sq(v) > 0.0f)) nn.at(i).fail("must be a non-zero finite vector");
        mesh.normals.push_back(normalize(v));
      }
    }
    if (n.has("uvs")) {  // texture coordinates [u, v], one per vertex
      Node nu = n["uvs"];
      nu.expect_array();
      if (nu.j.size() != mesh.vertices.size()) nu.fail("must hold one [u, v] per vertex");
      for (size_t i = 0; i < nu.j.size(); ++i) {
        Node e = nu.at(i);
        if (!e.j.is_array() || e.j.size() != 2) e.fail("must be [u, v]");
        mesh.uvs.push_back({e.at(0).number(), e.at(1).number()});
      }
    }
    if (n.has("tangents")) {  // [tx, ty, tz, sign], one per vertex
      Node nt = n["tangents"];
      nt.expect_array();
      if (nt.j.size() != mesh.vertices.size()) nt.fail("must hold one [tx, ty, tz, sign] per vertex");
      for (size_t i = 0; i < nt.j.size(); ++i) {
        Node e = nt.at(i);
        if (!e.j.is_array() || e.j.size() != 4) e.fail("must be [tx, ty, tz, sign]");
        mesh.tangents.push_back(Vec3(e.at(0).number(), e.at(1).number(), e.at(2).number()));
        mesh.tangent_signs.push_back(e.at(3).number() < 0.0f ? -1.0f : 1.0f);
      }
    }
  }
  mesh.name = n.string("name", mesh.name.empty() ? "mesh_" + std::to_string(index) : mesh.name);
  if (n.has("transform")) {
    Node tn = n["transform"];
    std::array<float, 16> m = tn.affine();
    Affine a = affine_from_rowmajor(m.data());
    for (Vec3& p : mesh.vertices) p = a.point(p);
    const Mat3& l = a.linear;
    // Normals go by the inverse transpose: the cofactor matrix, det times it.
    const Mat3 cof = Mat3::from_cols(cross(l.col(1), l.col(2)), cross(l.col(2), l.col(0)), cross(l.col(0), l.col(1)));
    double det = double(l.m[0][0]) * (double(l.m[1][1]) * l.m[2][2] - double(l.m[1][2]) * l.m[2][1]) -
                 double(l.m[0][1]) * (double(l.m[1][0]) * l.m[2][2] - double(l.m[1][2]) * l.m[2][0]) +
                 double(l.m[0][2]) * (double(l.m[1][0]) * l.m[2][1] - double(l.m[1][1]) * l.m[2][0]);
    if (!(std::fabs(det) > 0.0) || !std::isfinite(det)) tn.fail("is singular");
    // A mirror would turn the faces inside out: keep the winding's normals pointing the same way.
    if (det < 0.0)
      for (auto& tri : mesh.triangles) std::swap(tri[1], tri[2]);
    for (Vec3& nv : mesh.normals) nv = normalize(cof * nv) * (det < 0.0 ? -1.0f : 1.0f);
    // Tangents are surface directions (the linear part carries them); a mirror flips the bitangent's sign.
    for (Vec3& tv : mesh.tangents) tv = normalize(l * tv);
    if (det < 0.0)
      for (float& sign : mesh.tangent_signs) sign = -sign;
  }
  for (const Vec3& p : mesh.vertices)
    if (!is_finite(p)) n.fail("has a non-finite vertex");
  mesh.material = n.has("material") ? parse_material(n["material"], mesh.name, textures) : MeshMaterial{};
  if (!n.has("material")) mesh.material.name = mesh.name;
  prepare_mesh_tangents(mesh);
  return mesh;
}

Emitter parse_light(const Node& n) {
  n.expect_object();
  n.require("type");
  std::string type = n.choice("type", "", {"point", "sun", "area"});
  if (type == "point") {
    n.check_keys({"type", "name", "position", "power", "color", "radius", "visible_camera"});
    n.require("position");
    n.require("power");
    Vec3 pos = n["position"].vec3();
    float power = n.non_negative("power", 0.0f);
    return PointLight::from_blender(pos, power, n.colour("color", Vec3(1.0f)), n.non_negative("radius", 0.0f));
  }
  if (type == "sun") {
    n.check_keys({"type", "name", "direction", "transform", "strength", "color", "angle", "visible_camera"});
    if (n.has("direction") == n.has("transform")) n.fail("needs exactly one of \"direction\" (toward the sun) or \"transform\"");
    Vec3 to_sun;
    if (n.has("direction")) {
      to_sun = n["direction"].vec3();
      if (!(length(to_sun) > 0.0f)) n["direction"].fail("must not be zero");
    } else {
      std::array<float, 16> m = n["transform"].affine();
      to_sun = Vec3(m[2], m[6], m[10]);  // the object's +z axis: Blender suns shine along local -z
      if (!(length(to_sun) > 0.0f)) n["transform"].fail("has a zero z axis");
    }
    float strength = n.non_negative("strength", 1.0f);
    float angle = n.number_in("angle", 0.0f, 0.0f, kPi);
    return SunLight::from_blender(to_sun, strength, n.colour("color", Vec3(1.0f)), angle);
  }
  // area
  n.check_keys({"type", "name", "shape", "transform", "size", "size_y", "power", "color", "visible_camera"});
  n.require("transform");
  n.require("power");
  std::string shape = n.choice("shape", "square", {"square", "rectangle", "disk", "ellipse"});
  float size = n.positive("size", 1.0f);
  float size_y = n.positive("size_y", size);
  if (shape == "square" || shape == "disk") size_y = size;  // Blender ignores Size Y for these shapes
  std::array<float, 16> m = n["transform"].affine();
  Affine a = affine_from_rowmajor(m.data());
  if (!(length(a.linear.col(0)) > 0.0f) || !(length(a.linear.col(1)) > 0.0f) ||
      !(length(cross(a.linear.col(0), a.linear.col(1))) > 0.0f))
    n["transform"].fail("is degenerate in the light's plane (local x and y)");
  AreaShape s = (shape == "square" || shape == "rectangle") ? AreaShape::Rectangle : AreaShape::Ellipse;
  return AreaLight::from_blender(a, s, size, size_y, n.non_negative("power", 0.0f), n.colour("color", Vec3(1.0f)));
}

void parse_environment(const Node& n, SceneEnvironment& env) {
  if (n.j.is_null()) return;
  n.expect_object();
  n.require("type");
  std::string type = n.choice("type", "", {"latlong", "color", "sg"});
  if (type == "latlong") {
    n.check_keys({"type", "file", "strength", "rotation_z"});
    n.require("file");
    std::string path = n.file("file");
    float strength = n.non_negative("strength", 1.0f);
    float rot = n.number("rotation_z", 0.0f);
    env = with_context(n["file"], [&] { return Environment::load(path, strength, rot); });
  } else if (type == "color") {
    n.check_keys({"type", "color", "strength"});
    Vec3 c = n.colour("color", Vec3(1.0f));
    float strength = n.non_negative("strength", 1.0f);
    env = ConstantEnvironment(c, strength);
  } else {
    n.check_keys({"type", "lobes", "gamma", "raw"});
    int lobes = int(n.integer_in("lobes", SgEnvironment::kDefaultLobes, 1, 4096));
    float gamma = n.positive("gamma", SgEnvironment::kDefaultGamma);
    SgEnvironment sg(lobes, gamma);
    if (n.has("raw")) {
      Node r = n["raw"];
      if (r.j.is_array() && r.j.size() == 3 && r.j.at(0).is_number()) {
        Vec3 v = r.vec3();
        for (Vec3& x : sg.raw()) x = v;
      } else {
        r.expect_array();
        if (int(r.j.size()) != lobes)
          r.fail("must be one [r, g, b] or one per lobe (" + std::to_string(lobes) + "), got " + std::to_string(r.j.size()));
        for (int i = 0; i < lobes; ++i) sg.raw()[i] = r.at(size_t(i)).vec3();
      }
    }
    sg.update();
    env = std::move(sg);
  }
}

void parse_cameras(const Node& n, std::vector<Camera>& cams) {
  n.expect_array();
  for (size_t i = 0; i < n.j.size(); ++i) {
    Node c = n.at(i);
    c.expect_object();
    if (c.has("transforms")) {
      c.check_keys({"transforms", "width", "height"});
      std::string path = c.file("transforms");
      int w = int(c.integer_in("width", 0, 0, 65536)), h = int(c.integer_in("height", 0, 0, 65536));
      std::vector<Camera> more = with_context(c["transforms"], [&] { return load_transforms_json(path, w, h); });
      cams.insert(cams.end(), more.begin(), more.end());
    } else {
      c.check_keys({"name", "transform", "fov_x", "width", "height"});
      for (const char* k : {"transform", "fov_x", "width", "height"}) c.require(k);
      std::array<float, 16> m = c["transform"].matrix();
      float fov = c.number_in("fov_x", 0.0f, 0.0f, kPi, true);
      if (fov >= kPi) c["fov_x"].fail("must be below pi (radians)");
      int w = int(c.integer_in("width", 0, 1, 65536)), h = int(c.integer_in("height", 0, 1, 65536));
      std::string name = c.string("name", "camera_" + std::to_string(i));
      cams.push_back(with_context(c, [&] { return make_camera(m.data(), fov, w, h, name); }));
    }
  }
  std::set<std::string> seen;
  for (const Camera& cam : cams)
    if (!seen.insert(cam.name).second) n.fail("has two cameras named '" + cam.name + "'");
}

void parse_integrator(const Node& n, IntegratorSettings& s) {
  if (n.j.is_null()) return;
  n.check_keys({"spp", "bounces", "seed", "interaction", "tau_g", "geometric_criterion", "self_intersection",
                "self_range_scale", "fixed_offset", "fixed_range", "min_throughput", "pixel_filter", "filter_width",
                "light_selection", "russian_roulette", "min_light_bounces"});
  s.spp = int(n.integer_in("spp", s.spp, 1, 1 << 20));
  s.max_bounces = int(n.integer_in("bounces", s.max_bounces, 0, 1024));
  if (n.has("seed")) {
    Node sn = n["seed"];
    if (!sn.j.is_number_unsigned() && !(sn.j.is_number_integer() && sn.j.get<int64_t>() >= 0))
      sn.fail("must be a non-negative integer");
    s.seed = sn.j.get<uint64_t>();
  }
  const InteractionMode modes[] = {InteractionMode::Aggregate, InteractionMode::Discrete};
  s.interaction.mode = parse_interaction_mode(
      n.choice("interaction", interaction_mode_name(s.interaction.mode),
               {interaction_mode_name(modes[0]), interaction_mode_name(modes[1])}));
  s.interaction.tau_g = n.number_in("tau_g", s.interaction.tau_g, 0.0f, 1.0f);
  s.geometric_criterion = n.boolean("geometric_criterion", s.geometric_criterion);
  const SelfIntersection rules[] = {SelfIntersection::BackfaceAware, SelfIntersection::FixedOffset};
  s.self_intersection = parse_self_intersection(
      n.choice("self_intersection", self_intersection_name(s.self_intersection),
               {self_intersection_name(rules[0]), self_intersection_name(rules[1])}));
  if (n.contains("self_range_scale")) {
    Node r = n["self_range_scale"];
    if (r.j.is_null() || (r.j.is_string() && r.j.get<std::string>() == "inf"))
      s.self_range_scale = std::numeric_limits<float>::infinity();
    else if (r.j.is_number())
      s.self_range_scale = n.positive("self_range_scale", 0.0f);
    else
      r.fail("must be a positive number or \"inf\"");
  }
  // Lengths in scene units, bounded before they reach Embree (a 1e30 offset tripped its assertions):
  // a self-intersection offset or range past kMaxRayOffset is no offset but a teleport.
  constexpr float kMaxRayOffset = 1.0e4f;
  s.fixed_offset = n.number_in("fixed_offset", s.fixed_offset, 0.0f, kMaxRayOffset);
  s.fixed_range = n.number_in("fixed_range", s.fixed_range, 0.0f, kMaxRayOffset);
  s.min_throughput = n.number_in("min_throughput", s.min_throughput, 0.0f, 1.0e6f);
  s.filter.type = parse_pixel_filter(n.choice("pixel_filter", "blackman_harris", {"blackman_harris", "gaussian", "box"}));
  s.filter.width = n.number_in("filter_width", s.filter.width, 0.0f, 64.0f);  // pixels
  s.russian_roulette = n.boolean("russian_roulette", s.russian_roulette);
  s.min_light_bounces = int(n.integer_in("min_light_bounces", s.min_light_bounces, 0, 1024));
  s.light_selection = parse_light_selection(
      n.choice("light_selection", light_selection_name(s.light_selection),
               {light_selection_name(LightSelection::One), light_selection_name(LightSelection::All)}));
}

Scene parse_scene(const json& root, const Ctx& ctx) {
  Node n{root, "", ctx};
  if (!root.is_object()) ctx.fail("", std::string("the scene must be a JSON object, got ") + type_name(root));
  n.check_keys({"version", "comment", "brdf", "gaussians", "meshes", "lights", "environment", "cameras", "integrator"});
  if (n.has("version") && n.integer_in("version", 1, 1, 1) != 1) n.fail("unsupported version");
  Scene scene;
  scene.source_path = ctx.file;
  if (n.has("cameras")) parse_cameras(n["cameras"], scene.cameras);
  if (n.has("integrator")) parse_integrator(n["integrator"], scene.integrator);
  // The model: the file's "brdf" ("principled" = v1, as files before v2 wrote it), else the default (v2).
  scene.brdf_from_file = n.has("brdf");
  scene.integrator.brdf = *parse_bsdf_model(n.choice(
      "brdf", to_string(kDefaultBsdfModel), {"principled-v1", "principled-v2", "disney-simplified", "principled"}));
  if (n.has("environment")) parse_environment(n["environment"], scene.environment);
  if (n.has("lights")) {
    Node l = n["lights"];
    l.expect_array();
    for (size_t i = 0; i < l.j.size(); ++i) {
      scene.emitters.push_back(parse_light(l.at(i)));
      // Blender hides lights from camera rays unless Ray Visibility > Camera is on.
      scene.emitter_visible_camera.push_back(l.at(i).boolean("visible_camera", false) ? 1 : 0);
    }
  }
  if (n.has("meshes")) {
    Node m = n["meshes"];
    m.expect_array();
    TextureCache textures;  // materials sharing an image load it once
    for (size_t i = 0; i < m.j.size(); ++i) scene.meshes.push_back(parse_mesh(m.at(i), i, textures));
  }
  if (n.has("gaussians")) {
    Node g = n["gaussians"];
    g.expect_array();
    GaussianField all;
    std::optional<SurfaceShader> shader;
    for (size_t i = 0; i < g.j.size(); ++i) {
      Node e = g.at(i);
      e.check_keys({"file", "transform", "shader"});
      // One distribution for all splats (the interaction blends their materials).
      SurfaceShader s = *parse_surface_shader(e.choice("shader", "principled", {"principled", "principled-multiscatter"}));
      if (shader && *shader != s) e.fail("\"shader\" must be the same for every gaussians entry");
      shader = s;
      e.require("file");
      std::string path = e.file("file");
      GaussianField field = with_context(e["file"], [&] { return load_gaussians(path); });
      if (e.has("transform")) {
        Node t = e["transform"];
        std::array<float, 16> m = t.matrix();
        with_context(t, [&] {
          transform_gaussians(field, m.data(), path);
          return 0;
        });
      }
      append_gaussians(all, std::move(field));
    }
    all.shader = shader.value_or(SurfaceShader::PrincipledGGX);
    *scene.gaussians = std::move(all);
  }
  return scene;
}

}  // namespace

Scene scene_from_json_string(const std::string& text, const std::string& base_dir, const std::string& name) {
  const json root = parse_json_bounded(text, name);
  Ctx ctx{name, base_dir};
  return parse_scene(root, ctx);
}

MeshMaterial mesh_material_from_json_string(const std::string& text, const std::string& name) {
  const json root = parse_json_bounded(text, name);
  Ctx ctx{name, ""};
  Node n{root, "", ctx};
  n.expect_object();
  TextureCache textures;
  return parse_material(n, name, textures);
}

Scene load_scene_json(const std::string& path) {
  const std::string text = io::read_input_file(path, "scene file");  // regular files only, size cap
  fs::path p(path);
  return scene_from_json_string(text, p.has_parent_path() ? p.parent_path().string() : std::string(), path);
}

}  // namespace ptir
