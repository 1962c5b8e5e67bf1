// Triangle mesh loading from PLY and Wavefront OBJ. Polygons are fan-triangulated
// (v0, vk, vk+1); every index is range-checked; vertices must be finite.
#include "ptir/scene/mesh.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <string_view>

#include "ptir/core/error.h"
#include "ptir/io/ply.h"
#include "ptir/io/ply_detail.h"

namespace ptir {

namespace {

// Appends the fan triangulation of a polygon; polygons with fewer than 3 corners are skipped.
void add_fan(const std::vector<uint32_t>& poly, std::vector<std::array<uint32_t, 3>>& tris) {
  for (size_t k = 1; k + 1 < poly.size(); ++k) tris.push_back({poly[0], poly[k], poly[k + 1]});
}

// ---------------------------------------------------------------------------
// PLY: element vertex (x,y,z) and element face (list vertex_indices / vertex_index).

void load_ply_mesh(const std::string& path, TriangleMesh& mesh) {
  const io::PlyFile ply = io::read_ply(path);
  const io::PlyElement* vertex = ply.get("vertex");
  if (!vertex) throw Error(path, "mesh PLY has no 'vertex' element");
  std::vector<float> c[3];
  for (int k = 0; k < 3; ++k) c[k] = vertex->column_as_float(std::string(1, "xyz"[k]), path);
  mesh.vertices.resize(vertex->count);
  for (size_t i = 0; i < vertex->count; ++i) mesh.vertices[i] = Vec3(c[0][i], c[1][i], c[2][i]);
  // Shading normals: nx, ny, nz together (one of them alone is a broken file).
  int normal_columns = 0;
  for (const char* name : {"nx", "ny", "nz"}) normal_columns += vertex->get(name) != nullptr ? 1 : 0;
  if (normal_columns != 0 && normal_columns != 3)
    throw Error(path, "mesh PLY: vertex normals need all of nx, ny, nz");
  if (normal_columns == 3) {
    for (int k = 0; k < 3; ++k) c[k] = vertex->column_as_float(std::string("n") + "xyz"[k], path);
    mesh.normals.resize(vertex->count);
    for (size_t i = 0; i < vertex->count; ++i) {
      const Vec3 n(c[0][i], c[1][i], c[2][i]);
      if (!is_finite(n) || !(length_sq(n) > 0.0f))
        throw Error(path, "vertex " + std::to_string(i) + " has a zero or non-finite normal");
      mesh.normals[i] = normalize(n);
    }
  }

  // Texture coordinates: s, t (Blender's PLY names) or u, v; tangents: tx, ty, tz, tw.
  const char* uv_names[2][2] = {{"s", "t"}, {"u", "v"}};
  for (const auto& names : uv_names) {
    if (!vertex->get(names[0]) && !vertex->get(names[1])) continue;
    const std::vector<float> cu = vertex->column_as_float(names[0], path), cv = vertex->column_as_float(names[1], path);
    mesh.uvs.resize(vertex->count);
    for (size_t i = 0; i < vertex->count; ++i) {
      if (!std::isfinite(cu[i]) || !std::isfinite(cv[i]))
        throw Error(path, "vertex " + std::to_string(i) + " has a non-finite texture coordinate");
      mesh.uvs[i] = {cu[i], cv[i]};
    }
    break;
  }
  if (vertex->get("tx") || vertex->get("ty") || vertex->get("tz") || vertex->get("tw")) {
    for (int k = 0; k < 3; ++k) c[k] = vertex->column_as_float(std::string("t") + "xyz"[k], path);
    const std::vector<float> sign = vertex->column_as_float("tw", path);
    mesh.tangents.resize(vertex->count);
    mesh.tangent_signs.resize(vertex->count);
    for (size_t i = 0; i < vertex->count; ++i) {
      const Vec3 t(c[0][i], c[1][i], c[2][i]);
      if (!is_finite(t) || !std::isfinite(sign[i]))
        throw Error(path, "vertex " + std::to_string(i) + " has a non-finite tangent");
      mesh.tangents[i] = t;
      mesh.tangent_signs[i] = sign[i] < 0.0f ? -1.0f : 1.0f;
    }
  }

  const io::PlyElement* face = ply.get("face");
  if (!face) throw Error(path, "mesh PLY has no 'face' element (is it a point cloud or a Gaussian splat file?)");
  const io::PlyProperty* idx = face->get("vertex_indices");
  if (!idx) idx = face->get("vertex_index");
  if (!idx || !idx->is_list)
    throw Error(path, "mesh PLY: element 'face' needs a list property 'vertex_indices' (or 'vertex_index')");
  if (idx->type == io::PlyType::Float32 || idx->type == io::PlyType::Float64)
    throw Error(path,
                "mesh PLY: face vertex indices must be integers, found " + std::string(io::ply_type_name(idx->type)));

  const size_t is = io::ply_type_size(idx->type);
  std::vector<uint32_t> poly;
  for (size_t f = 0; f < face->count; ++f) {
    poly.clear();
    for (uint64_t j = idx->list_offsets[f]; j < idx->list_offsets[f + 1]; ++j) {
      const double v = io::ply_value_as_double(idx->list_data.data() + j * is, idx->type);
      if (v < 0 || v >= static_cast<double>(mesh.vertices.size()))
        throw Error(path, "face " + std::to_string(f) + " refers to vertex " +
                              std::to_string(static_cast<long long>(v)) + ", the mesh has " +
                              std::to_string(mesh.vertices.size()) + " vertices");
      poly.push_back(static_cast<uint32_t>(v));
    }
    add_fan(poly, mesh.triangles);
  }
}

// ---------------------------------------------------------------------------
// OBJ: "v x y z [w]" and "f a b c ..." with a, a/t, a/t/n, a//n and negative indices.

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

std::vector<std::string_view> obj_tokens(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i])) ++i;
    size_t j = i;
    while (j < line.size() && !is_blank(line[j])) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

bool parse_float(std::string_view tok, float& out) {
  if (!tok.empty() && tok[0] == '+') tok.remove_prefix(1);
  auto r = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return !tok.empty() && r.ec == std::errc() && r.ptr == tok.data() + tok.size();
}

void load_obj_mesh(const std::string& path, TriangleMesh& mesh) {
  const io::FileBytes file(path);
  const std::string_view text = file.view();
  std::vector<int64_t> poly;          // 0-based, not yet range-checked against the final count
  std::vector<size_t> triangle_line;  // source line of each triangle, for messages
  std::vector<std::array<int64_t, 3>> tris;
  size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line(text.data() + pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    const auto tok = obj_tokens(line);
    if (tok.empty()) continue;
    const std::string where = "line " + std::to_string(line_no) + ": ";
    if (tok[0] == "v") {
      Vec3 p;
      if (tok.size() < 4 || !parse_float(tok[1], p.x) || !parse_float(tok[2], p.y) || !parse_float(tok[3], p.z))
        throw Error(path, where + "bad vertex '" + std::string(line) + "'");
      mesh.vertices.push_back(p);
    } else if (tok[0] == "f") {
      poly.clear();
      for (size_t k = 1; k < tok.size(); ++k) {
        const std::string_view ref = tok[k].substr(0, tok[k].find('/'));  // vertex part of v/vt/vn
        int64_t v = 0;
        auto r = std::from_chars(ref.data(), ref.data() + ref.size(), v);
        if (ref.empty() || r.ec != std::errc() || r.ptr != ref.data() + ref.size() || v == 0)
          throw Error(path, where + "bad face index '" + std::string(tok[k]) + "'");
        // Negative indices count back from the last vertex defined so far.
        const int64_t index = v > 0 ? v - 1 : static_cast<int64_t>(mesh.vertices.size()) + v;
        if (index < 0)
          throw Error(path, where + "face index " + std::to_string(v) + " is out of range (" +
                                std::to_string(mesh.vertices.size()) + " vertices so far)");
        poly.push_back(index);
      }
      for (size_t k = 1; k + 1 < poly.size(); ++k) {
        tris.push_back({poly[0], poly[k], poly[k + 1]});
        triangle_line.push_back(line_no);
      }
    }
    // Everything else (vt, vn, o, g, s, usemtl, mtllib, comments) is ignored.
  }
  mesh.triangles.reserve(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    std::array<uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      if (tris[t][k] >= static_cast<int64_t>(mesh.vertices.size()))
        throw Error(path, "line " + std::to_string(triangle_line[t]) + ": face index " +
                              std::to_string(tris[t][k] + 1) + " is out of range (the file has " +
                              std::to_string(mesh.vertices.size()) + " vertices)");
      tri[k] = static_cast<uint32_t>(tris[t][k]);
    }
    mesh.triangles.push_back(tri);
  }
}

}  // namespace

TriangleMesh load_mesh(const std::string& path) {
  const std::filesystem::path p(path);
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  TriangleMesh mesh;
  mesh.name = p.stem().string();
  if (ext == ".ply")
    load_ply_mesh(path, mesh);
  else if (ext == ".obj")
    load_obj_mesh(path, mesh);
  else
    throw Error(path, "unsupported mesh format '" + ext + "' (expected .ply or .obj)");

  if (mesh.vertices.size() > static_cast<size_t>(UINT32_MAX))
    throw Error(path, "mesh has too many vertices for 32-bit indices");
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    if (!is_finite(mesh.vertices[i]))
      throw Error(path, "vertex " + std::to_string(i) + " has a NaN or infinite coordinate");
  if (mesh.triangles.empty()) throw Error(path, "mesh has no triangles");
  return mesh;
}

}  // namespace ptir
