// 3DGS PLY <-> GaussianField: finds the INRIA properties by name, checks them,
// activates them (exp scale, sigmoid opacity, normalised quaternion), reorders the
// SH, and reads the optional PTIR material properties. Saving writes every input
// property back unchanged plus the eight material properties.
#include "ptir/scene/gaussian_ply.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "ptir/core/error.h"
#include "ptir/io/ply_compressed.h"

namespace ptir {

namespace {

using io::PlyElement;
using io::PlyFile;

const char* const kRequired[] = {"x", "y", "z", "scale_0", "scale_1", "scale_2",
                                 "rot_0", "rot_1", "rot_2", "rot_3", "opacity"};

// A scalar column as float; NaN/Inf is refused with the property and the first bad index.
std::vector<float> finite_column(const PlyElement& v, const std::string& name, const std::string& path) {
  std::vector<float> col = v.column_as_float(name, path);
  for (size_t i = 0; i < col.size(); ++i) {
    if (!std::isfinite(col[i]))
      throw Error(path, "property '" + name + "' is " + (std::isnan(col[i]) ? "NaN" : "infinite") +
                            " at vertex " + std::to_string(i) + " (first bad vertex)");
  }
  return col;
}

// A short guess of what a non-splat PLY is, for the error message.
std::string looks_like(const PlyFile& ply, const PlyElement& v) {
  if (ply.get("face")) return "the file looks like a triangle mesh";
  const bool xyz = v.get("x") && v.get("y") && v.get("z");
  bool splat_props = false;
  for (size_t k = 3; k < std::size(kRequired); ++k) splat_props |= v.get(kRequired[k]) != nullptr;  // past x,y,z
  if (xyz && !splat_props) return "the file looks like a plain point cloud";
  return "the file looks like an incomplete or non-standard splat export";
}

// Names "<prefix>0 .. <prefix>(n-1)".
std::vector<std::string> numbered(const std::string& prefix, size_t n) {
  std::vector<std::string> out;
  for (size_t k = 0; k < n; ++k) out.push_back(prefix + std::to_string(k));
  return out;
}

// All of the group, none of it (returns false), or an error naming the missing ones.
bool optional_group(const PlyElement& v, const std::vector<std::string>& names, const std::string& path) {
  std::string missing;
  size_t found = 0;
  for (const std::string& n : names) {
    if (v.get(n)) ++found;
    else missing += (missing.empty() ? "" : ", ") + n;
  }
  if (found == 0) return false;
  if (found < names.size()) throw Error(path, "incomplete property group: missing " + missing);
  return true;
}

// SH degree from the number of f_rest_* properties (0, 9, 24 or 45), checking their numbering.
int sh_degree_from_rest(const PlyElement& v, const std::string& path) {
  size_t count = 0;
  for (const io::PlyProperty& p : v.properties)
    if (p.name.rfind("f_rest_", 0) == 0) ++count;
  int degree = -1;
  for (int d = 0; d <= 3; ++d)
    if (count == static_cast<size_t>(3 * ((d + 1) * (d + 1) - 1))) degree = d;
  if (degree < 0)
    throw Error(path, "unsupported SH: " + std::to_string(count) +
                          " f_rest_* properties (expected 0, 9, 24 or 45 for SH degree 0 to 3)");
  for (const std::string& name : numbered("f_rest_", count))
    if (!v.get(name)) throw Error(path, "f_rest_* properties are not numbered 0.." + std::to_string(count - 1) + ": missing " + name);
  return degree;
}

}  // namespace

GaussianField gaussians_from_ply(io::PlyFile ply, const std::string& path) {
  if (io::is_compressed_splat_ply(ply)) ply = io::decode_compressed_splat_ply(ply, path);
  const PlyElement* vp = ply.get("vertex");
  if (!vp) throw Error(path, "not a 3D Gaussian splat PLY: no 'vertex' element");
  const PlyElement& v = *vp;

  // Required properties: one message listing every missing one.
  std::string missing;
  for (const char* name : kRequired)
    if (!v.get(name)) missing += (missing.empty() ? "" : ", ") + std::string(name);
  if (!missing.empty())
    throw Error(path, "not a 3D Gaussian splat PLY: missing properties " + missing + " (" + looks_like(ply, v) + ")");
  if (v.count == 0) throw Error(path, "contains no Gaussians (the vertex element has 0 rows)");
  const size_t n = v.count;

  GaussianField f;
  f.position.resize(n);
  f.scale.resize(n);
  f.rotation.resize(n);
  f.opacity = finite_column(v, "opacity", path);

  // Geometry with activations.
  {
    std::vector<float> c[3];
    for (int k = 0; k < 3; ++k) c[k] = finite_column(v, std::string(1, "xyz"[k]), path);
    for (size_t i = 0; i < n; ++i) f.position[i] = Vec3(c[0][i], c[1][i], c[2][i]);
    for (int k = 0; k < 3; ++k) c[k] = finite_column(v, "scale_" + std::to_string(k), path);
    for (size_t i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) {
        float s = std::exp(c[k][i]);
        if (!std::isfinite(s))
          throw Error(path, "property 'scale_" + std::to_string(k) + "' at vertex " + std::to_string(i) +
                                " is too large: exp(" + std::to_string(c[k][i]) + ") overflows");
        f.scale[i][k] = std::max(s, std::numeric_limits<float>::min());  // keeps 1/scale finite
      }
    }
  }
  for (float& o : f.opacity) o = sigmoid(o);
  {
    std::vector<float> q[4];
    for (int k = 0; k < 4; ++k) q[k] = finite_column(v, "rot_" + std::to_string(k), path);
    for (size_t i = 0; i < n; ++i) {
      double len2 = 0;
      for (int k = 0; k < 4; ++k) len2 += static_cast<double>(q[k][i]) * q[k][i];
      if (len2 == 0.0)
        throw Error(path, "zero-length rotation quaternion (rot_0..rot_3 all zero) at vertex " + std::to_string(i));
      const double inv = 1.0 / std::sqrt(len2);
      for (int k = 0; k < 4; ++k) f.rotation[i][k] = static_cast<float>(q[k][i] * inv);
    }
  }

  // SH: sh[i*stride + k*3 + c]; the file stores f_rest channel-major, f_rest_[c*K + (k-1)].
  f.sh_degree = sh_degree_from_rest(v, path);
  const bool has_dc = optional_group(v, numbered("f_dc_", 3), path);
  {
    const size_t stride = static_cast<size_t>(f.sh_stride());
    const size_t K = stride / 3 - 1;
    f.sh.assign(n * stride, 0.0f);
    for (int c = 0; c < 3 && has_dc; ++c) {
      std::vector<float> col = finite_column(v, "f_dc_" + std::to_string(c), path);
      for (size_t i = 0; i < n; ++i) f.sh[i * stride + c] = col[i];
    }
    for (size_t c = 0; c < 3; ++c) {
      for (size_t k = 1; k <= K; ++k) {
        std::vector<float> col = finite_column(v, "f_rest_" + std::to_string(c * K + (k - 1)), path);
        for (size_t i = 0; i < n; ++i) f.sh[i * stride + k * 3 + c] = col[i];
      }
    }
  }

  // Material: albedo, roughness, metallic (defaults when absent).
  f.albedo.assign(n, Vec3(kDefaultAlbedo));
  if (optional_group(v, numbered("albedo_", 3), path)) {
    for (int c = 0; c < 3; ++c) {
      std::vector<float> col = finite_column(v, "albedo_" + std::to_string(c), path);
      for (size_t i = 0; i < n; ++i) f.albedo[i][c] = col[i];
    }
  }
  f.roughness = v.get("roughness") ? finite_column(v, "roughness", path) : std::vector<float>(n, kDefaultRoughness);
  f.metallic = v.get("metallic") ? finite_column(v, "metallic", path) : std::vector<float>(n, kDefaultMetallic);

  // Normals: from nx,ny,nz where non-zero, else the shortest axis.
  init_normals_shortest_axis(f);
  f.normals_from_file = false;
  if (optional_group(v, {"nx", "ny", "nz"}, path)) {
    std::vector<float> c[3];
    for (int k = 0; k < 3; ++k) c[k] = finite_column(v, std::string("n") + "xyz"[k], path);
    bool all = true;
    for (size_t i = 0; i < n; ++i) {
      const Vec3 nrm(c[0][i], c[1][i], c[2][i]);
      const float len = length(nrm);
      if (len > 0.0f && std::isfinite(len)) f.normal[i] = nrm / len;
      else all = false;
    }
    f.normals_from_file = all;
  }

  f.source = std::move(ply);
  f.source_path = path;
  return f;
}

GaussianField load_gaussians(const std::string& path) { return gaussians_from_ply(io::read_ply(path), path); }

namespace {

// The standard INRIA layout from activated values (a field built in code).
PlyFile standard_layout(const GaussianField& f) {
  const size_t n = f.size();
  PlyFile ply;
  ply.comments.push_back("written by PTIR");
  PlyElement v;
  v.name = "vertex";
  v.count = n;
  std::vector<float> col(n);
  auto put = [&](const std::string& name, auto&& value_of) {
    for (size_t i = 0; i < n; ++i) col[i] = value_of(i);
    v.set_float_column(name, col);
  };
  for (int k = 0; k < 3; ++k) put(std::string(1, "xyz"[k]), [&](size_t i) { return f.position[i][k]; });
  for (int k = 0; k < 3; ++k) put(std::string("n") + "xyz"[k], [&](size_t i) { return f.normal[i][k]; });
  const size_t stride = f.sh.empty() ? 0 : static_cast<size_t>(f.sh_stride());
  const size_t K = stride ? stride / 3 - 1 : 0;
  for (size_t c = 0; c < 3; ++c)
    put("f_dc_" + std::to_string(c), [&](size_t i) { return stride ? f.sh[i * stride + c] : 0.0f; });
  for (size_t c = 0; c < 3; ++c)
    for (size_t k = 1; k <= K; ++k)
      put("f_rest_" + std::to_string(c * K + k - 1), [&](size_t i) { return f.sh[i * stride + k * 3 + c]; });
  put("opacity", [&](size_t i) {
    // Clamped so an opacity of exactly 0 or 1 gives a finite logit.
    const double p = std::min(std::max(static_cast<double>(f.opacity[i]), 1e-7), 1.0 - 1e-7);
    return static_cast<float>(std::log(p / (1.0 - p)));
  });
  for (int k = 0; k < 3; ++k)
    put("scale_" + std::to_string(k),
        [&](size_t i) { return std::log(std::max(f.scale[i][k], std::numeric_limits<float>::min())); });
  for (int k = 0; k < 4; ++k) put("rot_" + std::to_string(k), [&](size_t i) { return f.rotation[i][k]; });
  ply.elements.push_back(std::move(v));
  return ply;
}

}  // namespace

void save_gaussians(const std::string& path, const GaussianField& f) {
  const size_t n = f.size();
  if (f.scale.size() != n || f.rotation.size() != n || f.opacity.size() != n || f.normal.size() != n ||
      f.albedo.size() != n || f.roughness.size() != n || f.metallic.size() != n ||
      (!f.sh.empty() && f.sh.size() != n * static_cast<size_t>(f.sh_stride())))
    throw Error(path, "cannot save: the Gaussian field's arrays have inconsistent sizes");

  // Every input property is kept as is. For a SuperSplat compressed input, source already
  // holds the decoded standard layout, so that is what gets written (not the packed form).
  PlyFile out;
  if (const PlyElement* src = f.source.get("vertex")) {
    if (src->count != n)
      throw Error(path, "cannot save: the field has " + std::to_string(n) + " Gaussians but its source PLY (" +
                            f.source_path + ") has " + std::to_string(src->count));
    out = f.source;
  } else {
    out = standard_layout(f);
  }

  // Material properties, overwritten or added as float32.
  PlyElement& v = *out.get("vertex");
  std::vector<float> col(n);
  for (int c = 0; c < 3; ++c) {
    for (size_t i = 0; i < n; ++i) col[i] = f.albedo[i][c];
    v.set_float_column("albedo_" + std::to_string(c), col);
  }
  v.set_float_column("roughness", f.roughness);
  v.set_float_column("metallic", f.metallic);
  for (int k = 0; k < 3; ++k) {
    for (size_t i = 0; i < n; ++i) col[i] = f.normal[i][k];
    v.set_float_column(std::string("n") + "xyz"[k], col);
  }
  io::write_ply(path, out);
}

}  // namespace ptir
