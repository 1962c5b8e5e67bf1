// Decoder for SuperSplat's compressed PLY (the layout written by PlayCanvas
// SuperSplat and splat-transform; see their compressed-ply reader/writer).
//
// Layout, as documented by PlayCanvas:
//   element chunk  (one per 256 consecutive splats), float properties
//     min_x min_y min_z max_x max_y max_z                 position bounds
//     min_scale_x .. min_scale_z max_scale_x .. max_scale_z  log-scale bounds
//     [min_r min_g min_b max_r max_g max_b]               colour bounds (newer files)
//   element vertex, uint32 properties
//     packed_position  x:11 bits (31..21) y:10 bits (20..11) z:11 bits (10..0), unorm,
//                      lerp(min, max, t) with the chunk's bounds
//     packed_rotation  bits 31..30 = index (in w,x,y,z order) of the largest |component|,
//                      then the other three in order, 10 bits each (29..20, 19..10, 9..0);
//                      v = (unorm - 0.5) * sqrt(2); the largest is sqrt(1 - sum v^2)
//                      (the encoder flips the quaternion so the largest is positive)
//     packed_scale     log scale, 11/10/11 unorm like the position, scale bounds
//     packed_color     r:8 (31..24) g:8 (23..16) b:8 (15..8) a:8 (7..0), unorm;
//                      colour = lerp(min_c, max_c, t) when the chunk has colour bounds,
//                      else t; f_dc = (colour - 0.5) / C0; opacity = logit(a)
//   element sh (optional), uchar f_rest_0 .. f_rest_{N-1}, N = 9, 24 or 45, in the
//     standard channel-major order; q -> n = 0 for 0, 1 for 255, else (q + 0.5) / 256;
//     f_rest = (n - 0.5) * 8.
#include "ptir/io/ply_compressed.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "ptir/core/error.h"

namespace ptir::io {

namespace {

constexpr size_t kChunkSize = 256;
constexpr double kShC0 = 0.28209479177387814;

const char* const kPacked[] = {"packed_position", "packed_rotation", "packed_scale", "packed_color"};
const char* const kChunkBounds[] = {"min_x",       "min_y",       "min_z",       "max_x",
                                    "max_y",       "max_z",       "min_scale_x", "min_scale_y",
                                    "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z"};
const char* const kChunkColour[] = {"min_r", "min_g", "min_b", "max_r", "max_g", "max_b"};

double unorm(uint32_t bits, int width) {
  const uint32_t max = (1u << width) - 1u;
  return static_cast<double>(bits & max) / static_cast<double>(max);
}

double lerp(double a, double b, double t) { return a * (1.0 - t) + b * t; }

// A packed uint32 column (uint or int, both 4 bytes) as raw words.
std::vector<uint32_t> packed_words(const PlyElement& vertex, const char* name, const std::string& path) {
  const PlyProperty* p = vertex.get(name);
  if (!p) throw Error(path, std::string("compressed splat PLY: vertex property '") + name + "' is missing");
  if (p->is_list || (p->type != PlyType::UInt32 && p->type != PlyType::Int32))
    throw Error(path, std::string("compressed splat PLY: vertex property '") + name +
                          "' must be a 32-bit unsigned integer, found " +
                          (p->is_list ? "a list" : ply_type_name(p->type)));
  std::vector<uint32_t> words(vertex.count);
  if (vertex.count) std::memcpy(words.data(), p->data.data(), vertex.count * 4);
  return words;
}

// A chunk bound column as double (any numeric type is accepted).
std::vector<double> chunk_column(const PlyElement& chunk, const char* name, const std::string& path) {
  const PlyProperty* p = chunk.get(name);
  if (!p || p->is_list)
    throw Error(path, std::string("compressed splat PLY: chunk property '") + name + "' is missing or not a scalar");
  std::vector<double> out(chunk.count);
  for (size_t i = 0; i < chunk.count; ++i) out[i] = p->as_double(i);
  return out;
}

void add_float(PlyElement& el, const std::string& name, const std::vector<float>& values) {
  el.set_float_column(name, values);
}

// Smallest-three quaternion -> (w, x, y, z).
void decode_rotation(uint32_t word, float q[4]) {
  const double s = std::sqrt(2.0);
  const double a = (unorm(word >> 20, 10) - 0.5) * s;
  const double b = (unorm(word >> 10, 10) - 0.5) * s;
  const double c = (unorm(word, 10) - 0.5) * s;
  const double m = std::sqrt(std::max(0.0, 1.0 - (a * a + b * b + c * c)));
  const unsigned largest = word >> 30;
  const double rest[3] = {a, b, c};
  for (unsigned k = 0, j = 0; k < 4; ++k) q[k] = static_cast<float>(k == largest ? m : rest[j++]);
}

}  // namespace

bool is_compressed_splat_ply(const PlyFile& ply) {
  const PlyElement* vertex = ply.get("vertex");
  if (!ply.get("chunk") || !vertex) return false;
  for (const char* name : kPacked)
    if (vertex->get(name)) return true;
  return false;
}

PlyFile decode_compressed_splat_ply(const PlyFile& ply, const std::string& path) {
  const PlyElement* chunk = ply.get("chunk");
  const PlyElement* vertex = ply.get("vertex");
  if (!chunk || !vertex) throw Error(path, "compressed splat PLY: needs elements 'chunk' and 'vertex'");
  const size_t n = vertex->count;

  // Packed words and chunk bounds.
  std::vector<uint32_t> pos_w = packed_words(*vertex, kPacked[0], path);
  std::vector<uint32_t> rot_w = packed_words(*vertex, kPacked[1], path);
  std::vector<uint32_t> scl_w = packed_words(*vertex, kPacked[2], path);
  std::vector<uint32_t> col_w = packed_words(*vertex, kPacked[3], path);
  const size_t chunks_needed = n / kChunkSize + (n % kChunkSize ? 1 : 0);
  if (chunk->count < chunks_needed)
    throw Error(path, "compressed splat PLY: " + std::to_string(n) + " splats need " + std::to_string(chunks_needed) +
                          " chunks of 256, the file has " + std::to_string(chunk->count));
  std::vector<std::vector<double>> bounds;
  for (const char* name : kChunkBounds) bounds.push_back(chunk_column(*chunk, name, path));
  int colour_props = 0;
  for (const char* name : kChunkColour) colour_props += chunk->get(name) ? 1 : 0;
  if (colour_props != 0 && colour_props != 6)
    throw Error(path, "compressed splat PLY: chunk has only some of the colour bounds min_r..max_b");
  std::vector<std::vector<double>> colour_bounds;
  if (colour_props == 6)
    for (const char* name : kChunkColour) colour_bounds.push_back(chunk_column(*chunk, name, path));

  // Decode geometry and colour, splat by splat.
  std::vector<float> xyz[3], scale[3], dc[3], rot[4], opacity(n);
  for (int k = 0; k < 3; ++k) {
    xyz[k].resize(n);
    scale[k].resize(n);
    dc[k].resize(n);
  }
  for (auto& r : rot) r.resize(n);
  const int widths[3] = {11, 10, 11}, shifts[3] = {21, 11, 0};
  for (size_t i = 0; i < n; ++i) {
    const size_t c = i / kChunkSize;
    for (int k = 0; k < 3; ++k) {
      xyz[k][i] = static_cast<float>(lerp(bounds[k][c], bounds[3 + k][c], unorm(pos_w[i] >> shifts[k], widths[k])));
      scale[k][i] =
          static_cast<float>(lerp(bounds[6 + k][c], bounds[9 + k][c], unorm(scl_w[i] >> shifts[k], widths[k])));
      double t = unorm(col_w[i] >> (24 - 8 * k), 8);
      if (!colour_bounds.empty()) t = lerp(colour_bounds[k][c], colour_bounds[3 + k][c], t);
      dc[k][i] = static_cast<float>((t - 0.5) / kShC0);
    }
    float q[4];
    decode_rotation(rot_w[i], q);
    for (int k = 0; k < 4; ++k) rot[k][i] = q[k];
    // Alpha 0 or 255 would give an infinite logit: keep it within [1e-6, 1 - 1e-6].
    const double a = std::min(std::max(unorm(col_w[i], 8), 1e-6), 1.0 - 1e-6);
    opacity[i] = static_cast<float>(std::log(a / (1.0 - a)));
  }

  // Optional 8-bit SH rest coefficients.
  std::vector<std::vector<float>> rest;
  if (const PlyElement* sh = ply.get("sh")) {
    const size_t m = sh->properties.size();
    if (m != 9 && m != 24 && m != 45)
      throw Error(path, "compressed splat PLY: element 'sh' has " + std::to_string(m) +
                            " properties (expected 9, 24 or 45 f_rest values)");
    if (sh->count != n)
      throw Error(path, "compressed splat PLY: element 'sh' has " + std::to_string(sh->count) + " rows for " +
                            std::to_string(n) + " splats");
    for (size_t k = 0; k < m; ++k) {
      const PlyProperty* p = sh->get("f_rest_" + std::to_string(k));
      if (!p || p->is_list || p->type != PlyType::UInt8)
        throw Error(path, "compressed splat PLY: element 'sh' needs uchar f_rest_" + std::to_string(k));
      std::vector<float> v(n);
      for (size_t i = 0; i < n; ++i) {
        const uint8_t q = p->data[i];
        const double u = q == 0 ? 0.0 : (q == 255 ? 1.0 : (q + 0.5) / 256.0);
        v[i] = static_cast<float>((u - 0.5) * 8.0);
      }
      rest.push_back(std::move(v));
    }
  }

  // Assemble the standard layout.
  PlyFile out;
  out.format = PlyFormat::BinaryLittleEndian;
  out.comments = ply.comments;
  out.comments.push_back("decoded from a SuperSplat compressed PLY by PTIR");
  out.obj_info = ply.obj_info;
  for (const PlyElement& el : ply.elements) {
    if (el.name == "chunk" || el.name == "sh") continue;
    if (el.name != "vertex") {
      out.elements.push_back(el);
      continue;
    }
    PlyElement v;
    v.name = "vertex";
    v.count = n;
    const char* axes[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) add_float(v, axes[k], xyz[k]);
    for (int k = 0; k < 3; ++k) add_float(v, "f_dc_" + std::to_string(k), dc[k]);
    for (size_t k = 0; k < rest.size(); ++k) add_float(v, "f_rest_" + std::to_string(k), rest[k]);
    add_float(v, "opacity", opacity);
    for (int k = 0; k < 3; ++k) add_float(v, "scale_" + std::to_string(k), scale[k]);
    for (int k = 0; k < 4; ++k) add_float(v, "rot_" + std::to_string(k), rot[k]);
    // Keep any other per-splat property the file carries.
    for (const PlyProperty& p : el.properties) {
      bool packed = false;
      for (const char* name : kPacked) packed |= p.name == name;
      if (!packed && v.find(p.name) < 0) v.properties.push_back(p);
    }
    out.elements.push_back(std::move(v));
  }
  return out;
}

}  // namespace ptir::io
