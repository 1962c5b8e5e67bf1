// 3DGS PLY <-> GaussianField: finds the INRIA properties by name, checks them,
// activates them (exp scale, sigmoid opacity, normalised quaternion), reorders the
// SH, and reads the optional PTIR material properties (in [0, 1]: material_range.h).
// Saving writes every input property back unchanged plus the eight material properties.
#include "ptir/scene/gaussian_ply.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>

#include "ptir/core/error.h"
#include "ptir/io/ply_compressed.h"
#include "ptir/material/material_range.h"

namespace ptir {

namespace {

using io::PlyElement;
using io::PlyFile;

const char* const kRequired[] = {"x",     "y",     "z",     "scale_0", "scale_1", "scale_2",
                                 "rot_0", "rot_1", "rot_2", "rot_3",   "opacity"};

// Read-only view of one scalar property, value by value as float, without copying the
// column. NaN/Inf is refused with the property name and the vertex index.
class Column {
 public:
  Column() = default;
  Column(const PlyElement& v, const std::string& name, const std::string& path) : name_(name), path_(&path) {
    p_ = v.get(name);
    if (!p_) throw Error(path, "element 'vertex' has no property '" + name + "'");
    if (p_->is_list) throw Error(path, "property '" + name + "' is a list, expected a scalar");
    if (p_->data.size() != v.count * io::ply_type_size(p_->type))
      throw Error(path, "property '" + name + "' has the wrong number of values");
    f32_ = p_->type == io::PlyType::Float32;
  }
  explicit operator bool() const { return p_ != nullptr; }

  float operator()(size_t i) const {
    float x;
    if (f32_)
      std::memcpy(&x, p_->data.data() + 4 * i, 4);
    else
      x = p_->as_float(i);
    if (!std::isfinite(x)) fail(i, x);
    return x;
  }

 private:
  [[noreturn]] void fail(size_t i, float x) const {
    throw Error(*path_, "property '" + name_ + "' is " + (std::isnan(x) ? "NaN" : "infinite") + " at vertex " +
                            std::to_string(i) + " (first bad vertex)");
  }
  const io::PlyProperty* p_ = nullptr;
  std::string name_;
  const std::string* path_ = nullptr;
  bool f32_ = false;
};

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
    if (v.get(n))
      ++found;
    else
      missing += (missing.empty() ? "" : ", ") + n;
  }
  if (found == 0) return false;
  if (found < names.size()) throw Error(path, "incomplete property group: missing " + missing);
  return true;
}

// SH degree from the number of f_rest_* properties (0, 9, 24, 45 or 72), checking their numbering.
int sh_degree_from_rest(const PlyElement& v, const std::string& path) {
  size_t count = 0;
  for (const io::PlyProperty& p : v.properties)
    if (p.name.rfind("f_rest_", 0) == 0) ++count;
  int degree = -1;
  for (int d = 0; d <= kMaxShDegree; ++d)
    if (count == static_cast<size_t>(3 * ((d + 1) * (d + 1) - 1))) degree = d;
  if (degree < 0)
    throw Error(path, "unsupported SH: " + std::to_string(count) +
                          " f_rest_* properties (expected 0, 9, 24, 45 or 72 for SH degree 0 to 4)");
  for (const std::string& name : numbered("f_rest_", count))
    if (!v.get(name))
      throw Error(path, "f_rest_* properties are not numbered 0.." + std::to_string(count - 1) + ": missing " + name);
  return degree;
}

// Geometry with activations: exp scale, sigmoid opacity, normalised quaternion
// (surfels: a 2DGS file's flat Gaussians, kSurfelThickness thick).
void read_geometry(const PlyElement& v, bool surfels, const std::string& path, GaussianField& f) {
  const size_t n = v.count;
  const Column x(v, "x", path), y(v, "y", path), z(v, "z", path), op(v, "opacity", path);
  const Column s[3] = {{v, "scale_0", path}, {v, "scale_1", path}, surfels ? Column() : Column(v, "scale_2", path)};
  const Column q[4] = {{v, "rot_0", path}, {v, "rot_1", path}, {v, "rot_2", path}, {v, "rot_3", path}};
  for (size_t i = 0; i < n; ++i) {
    f.position[i] = Vec3(x(i), y(i), z(i));
    f.opacity[i] = sigmoid(op(i));
    for (int k = 0; k < (surfels ? 2 : 3); ++k) {
      const float raw = s[k](i), e = std::exp(raw);
      if (!std::isfinite(e))
        throw Error(path, "property 'scale_" + std::to_string(k) + "' at vertex " + std::to_string(i) +
                              " is too large: exp(" + std::to_string(raw) + ") overflows");
      f.scale[i][k] = std::max(e, std::numeric_limits<float>::min());  // keeps 1/scale finite
    }
    if (surfels) f.scale[i][2] = kSurfelThickness * std::min(f.scale[i][0], f.scale[i][1]);
    double qd[4], len2 = 0;
    for (int k = 0; k < 4; ++k) {
      qd[k] = q[k](i);
      len2 += qd[k] * qd[k];
    }
    if (len2 == 0.0)
      throw Error(path, "zero-length rotation quaternion (rot_0..rot_3 all zero) at vertex " + std::to_string(i));
    const double inv = 1.0 / std::sqrt(len2);
    for (int k = 0; k < 4; ++k) f.rotation[i][k] = static_cast<float>(qd[k] * inv);
  }
}

// SH: sh[i*stride + k*3 + c]; the file stores f_rest channel-major, f_rest_[c*K + (k-1)].
// Filled in blocks of Gaussians so the strided writes stay in cache.
void read_sh(const PlyElement& v, bool has_dc, const std::string& path, GaussianField& f) {
  const size_t n = v.count;
  const size_t stride = static_cast<size_t>(f.sh_stride());
  const size_t K = stride / 3 - 1;
  std::vector<Column> src(stride);  // src[k*3 + c]; empty for a missing DC
  for (size_t c = 0; c < 3; ++c) {
    if (has_dc) src[c] = Column(v, "f_dc_" + std::to_string(c), path);
    for (size_t k = 1; k <= K; ++k) src[k * 3 + c] = Column(v, "f_rest_" + std::to_string(c * K + (k - 1)), path);
  }
  f.sh.assign(n * stride, 0.0f);
  constexpr size_t kBlock = 1024;
  for (size_t i0 = 0; i0 < n; i0 += kBlock) {
    const size_t i1 = std::min(n, i0 + kBlock);
    for (size_t j = 0; j < stride; ++j) {
      if (!src[j]) continue;
      float* dst = f.sh.data() + j;
      for (size_t i = i0; i < i1; ++i) dst[i * stride] = src[j](i);
    }
  }
}

// Material: albedo, roughness, metallic (defaults when absent), and the fixed
// Principled inputs, only when the file has them (else Blender's defaults).
void read_material(const PlyElement& v, const std::string& path, GaussianField& f) {
  const size_t n = v.count;
  f.albedo.assign(n, Vec3(kDefaultAlbedo));
  if (optional_group(v, numbered("albedo_", 3), path)) {
    const Column a[3] = {{v, "albedo_0", path}, {v, "albedo_1", path}, {v, "albedo_2", path}};
    for (size_t i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) check_material_value(a[c](i), path, "albedo_" + std::to_string(c), i);
      f.albedo[i] = Vec3(a[0](i), a[1](i), a[2](i));
    }
  }
  f.roughness.assign(n, kDefaultRoughness);
  if (v.get("roughness")) {
    const Column r(v, "roughness", path);
    for (size_t i = 0; i < n; ++i) check_material_value(f.roughness[i] = r(i), path, "roughness", i);
  }
  f.metallic.assign(n, kDefaultMetallic);
  if (v.get("metallic")) {
    const Column m(v, "metallic", path);
    for (size_t i = 0; i < n; ++i) check_material_value(f.metallic[i] = m(i), path, "metallic", i);
  }
  f.specular.clear();
  f.specular_tint.clear();
  if (v.get("specular")) {
    const Column s(v, "specular", path);
    f.specular.resize(n);
    for (size_t i = 0; i < n; ++i) f.specular[i] = s(i);
  }
  if (v.get("specular_tint")) {
    const Column t(v, "specular_tint", path);
    f.specular_tint.resize(n);
    for (size_t i = 0; i < n; ++i) f.specular_tint[i] = t(i);
  }
}

// Normals: from nx,ny,nz where non-zero, else the shortest axis.
void read_normals(const PlyElement& v, const std::string& path, GaussianField& f) {
  const size_t n = v.count;
  init_normals_shortest_axis(f);
  f.normals_from_file = false;
  if (optional_group(v, {"nx", "ny", "nz"}, path)) {
    const Column c[3] = {{v, "nx", path}, {v, "ny", path}, {v, "nz", path}};
    bool all = true;
    for (size_t i = 0; i < n; ++i) {
      const Vec3 nrm(c[0](i), c[1](i), c[2](i));
      const float len = length(nrm);
      if (len > 0.0f && std::isfinite(len))
        f.normal[i] = nrm / len;
      else
        all = false;
    }
    f.normals_from_file = all;
  }
}

}  // namespace

GaussianField gaussians_from_ply(io::PlyFile ply, const std::string& path) {
  if (io::is_compressed_splat_ply(ply)) ply = io::decode_compressed_splat_ply(ply, path);
  const PlyElement* vp = ply.get("vertex");
  if (!vp) throw Error(path, "not a 3D Gaussian splat PLY: no 'vertex' element");
  const PlyElement& v = *vp;

  // Required properties: one message listing every missing one. A 2DGS file (surfels:
  // scale_0 and scale_1 only) is a field of flat Gaussians (surfel_thickness below).
  const bool surfels = v.get("scale_0") && v.get("scale_1") && !v.get("scale_2");
  std::string missing;
  for (const char* name : kRequired)
    if (!v.get(name) && !(surfels && std::string(name) == "scale_2"))
      missing += (missing.empty() ? "" : ", ") + std::string(name);
  if (!missing.empty())
    throw Error(path, "not a 3D Gaussian splat PLY: missing properties " + missing + " (" + looks_like(ply, v) + ")");
  if (v.count == 0) throw Error(path, "contains no Gaussians (the vertex element has 0 rows)");
  const size_t n = v.count;

  GaussianField f;
  f.position.resize(n);
  f.scale.resize(n);
  f.rotation.resize(n);
  f.opacity.resize(n);
  read_geometry(v, surfels, path, f);
  f.sh_degree = sh_degree_from_rest(v, path);
  const bool has_dc = optional_group(v, numbered("f_dc_", 3), path);
  read_sh(v, has_dc, path, f);
  read_material(v, path, f);
  read_normals(v, path, f);

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
  if (f.specular.size() == n) v.set_float_column("specular", f.specular);
  if (f.specular_tint.size() == n) v.set_float_column("specular_tint", f.specular_tint);
  for (int k = 0; k < 3; ++k) {
    for (size_t i = 0; i < n; ++i) col[i] = f.normal[i][k];
    v.set_float_column(std::string("n") + "xyz"[k], col);
  }
  io::write_ply(path, out);
}

}  // namespace ptir
