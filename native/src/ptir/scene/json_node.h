// Reading JSON with messages that name the file and the JSON path of the offending
// value ("scene.json: meshes[2].material.roughness must be in [0, 1]"): the node
// helpers the scene-file parser (scene_json.cpp) is written with.
#pragma once

#include <array>
#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/math/vec.h"

namespace ptir::json_node {

namespace fs = std::filesystem;
using json = nlohmann::json;


struct Ctx {
  std::string file;      // for messages
  std::string base_dir;  // relative paths resolve against this
  [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
    throw Error(file, where.empty() ? problem : where + " " + problem);
  }
  std::string resolve(const std::string& p) const {
    fs::path path(p);
    if (path.is_absolute() || base_dir.empty()) return path.lexically_normal().string();
    return (fs::path(base_dir) / path).lexically_normal().string();
  }
};

inline const char* type_name(const json& j) {
  switch (j.type()) {
    case json::value_t::null: return "null";
    case json::value_t::object: return "an object";
    case json::value_t::array: return "an array";
    case json::value_t::string: return "a string";
    case json::value_t::boolean: return "a boolean";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float: return "a number";
    default: return "an unsupported value";
  }
}

struct Node {
  const json& j;
  std::string path;
  const Ctx& ctx;

  [[noreturn]] void fail(const std::string& problem) const { ctx.fail(path, problem); }
  std::string key_path(const std::string& key) const { return path.empty() ? key : path + "." + key; }
  Node operator[](const std::string& key) const { return Node{j.at(key), key_path(key), ctx}; }
  Node at(size_t i) const { return Node{j.at(i), path + "[" + std::to_string(i) + "]", ctx}; }
  bool has(const std::string& key) const { return j.is_object() && j.contains(key) && !j.at(key).is_null(); }
  bool contains(const std::string& key) const { return j.is_object() && j.contains(key); }

  void expect_object() const {
    if (!j.is_object()) fail(std::string("must be an object, got ") + type_name(j));
  }
  void expect_array() const {
    if (!j.is_array()) fail(std::string("must be a list, got ") + type_name(j));
  }
  // Every key must be one of `allowed`.
  void check_keys(std::initializer_list<const char*> allowed) const {
    expect_object();
    for (auto it = j.begin(); it != j.end(); ++it) {
      bool ok = false;
      for (const char* a : allowed) ok = ok || it.key() == a;
      if (!ok) {
        std::string list;
        for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
        ctx.fail(key_path(it.key()), "is not a known key (expected one of: " + list + ")");
      }
    }
  }
  void require(const std::string& key) const {
    if (!has(key)) ctx.fail(key_path(key), "is required");
  }

  float number() const {
    if (!j.is_number()) fail(std::string("must be a number, got ") + type_name(j));
    double v = j.get<double>();
    if (!std::isfinite(v) || std::fabs(v) > 3.0e38) fail("must be a finite number");
    return float(v);
  }
  float number(const std::string& key, float def) const { return has(key) ? (*this)[key].number() : def; }
  float number_in(const std::string& key, float def, float lo, float hi, bool lo_open = false) const {
    if (!has(key)) return def;
    Node n = (*this)[key];
    float v = n.number();
    if (v < lo || v > hi || (lo_open && v == lo)) {
      std::ostringstream s;
      s << "must be in " << (lo_open ? "(" : "[") << lo << ", " << hi << "], got " << v;
      n.fail(s.str());
    }
    return v;
  }
  float positive(const std::string& key, float def) const {
    return number_in(key, def, 0.0f, std::numeric_limits<float>::max(), true);
  }
  float non_negative(const std::string& key, float def) const {
    return number_in(key, def, 0.0f, std::numeric_limits<float>::max());
  }
  int64_t integer() const {
    if (!j.is_number_integer() && !j.is_number_unsigned()) {
      if (j.is_number_float()) {
        double v = j.get<double>();
        if (std::floor(v) == v && std::fabs(v) < 9e15) return int64_t(v);
      }
      fail(std::string("must be an integer, got ") + (j.is_number() ? j.dump() : type_name(j)));
    }
    if (j.is_number_unsigned() && j.get<uint64_t>() > uint64_t(std::numeric_limits<int64_t>::max()))
      fail("is too large");
    return j.get<int64_t>();
  }
  int64_t integer_in(const std::string& key, int64_t def, int64_t lo, int64_t hi) const {
    if (!has(key)) return def;
    Node n = (*this)[key];
    int64_t v = n.integer();
    if (v < lo || v > hi) n.fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(v));
    return v;
  }
  bool boolean(const std::string& key, bool def) const {
    if (!has(key)) return def;
    Node n = (*this)[key];
    if (!n.j.is_boolean()) n.fail(std::string("must be true or false, got ") + type_name(n.j));
    return n.j.get<bool>();
  }
  std::string string() const {
    if (!j.is_string()) fail(std::string("must be a string, got ") + type_name(j));
    return j.get<std::string>();
  }
  std::string string(const std::string& key, const std::string& def) const { return has(key) ? (*this)[key].string() : def; }
  std::string choice(const std::string& key, const std::string& def, std::initializer_list<const char*> options) const {
    if (!has(key)) return def;
    Node n = (*this)[key];
    std::string v = n.string();
    std::string list;
    for (const char* o : options) {
      if (v == o) return v;
      list += (list.empty() ? "'" : ", '") + std::string(o) + "'";
    }
    n.fail("must be one of " + list + ", got '" + v + "'");
  }
  Vec3 vec3() const {
    if (!j.is_array() || j.size() != 3) fail("must be a list of 3 numbers");
    return Vec3(at(0).number(), at(1).number(), at(2).number());
  }
  Vec3 vec3(const std::string& key, Vec3 def) const { return has(key) ? (*this)[key].vec3() : def; }
  Vec3 colour(const std::string& key, Vec3 def) const {
    if (!has(key)) return def;
    Node n = (*this)[key];
    Vec3 c = n.vec3();
    if (c.x < 0 || c.y < 0 || c.z < 0) n.fail("must not be negative");
    return c;
  }
  // 4x4 row-major: [[4 numbers] x 4] or 16 numbers.
  std::array<float, 16> matrix() const {
    std::array<float, 16> m{};
    if (j.is_array() && j.size() == 16 && j.at(0).is_number()) {
      for (size_t i = 0; i < 16; ++i) m[i] = at(i).number();
    } else if (j.is_array() && j.size() == 4) {
      for (size_t r = 0; r < 4; ++r) {
        Node row = at(r);
        if (!row.j.is_array() || row.j.size() != 4) row.fail("must be a list of 4 numbers (a row of the 4x4 matrix)");
        for (size_t c = 0; c < 4; ++c) m[r * 4 + c] = row.at(c).number();
      }
    } else {
      fail("must be a 4x4 matrix: 4 rows of 4 numbers (row-major), or 16 numbers");
    }
    return m;
  }
  // An affine matrix (last row 0 0 0 1).
  std::array<float, 16> affine() const {
    std::array<float, 16> m = matrix();
    if (m[12] != 0.0f || m[13] != 0.0f || m[14] != 0.0f || m[15] != 1.0f)
      fail("must be an affine matrix (last row 0, 0, 0, 1)");
    return m;
  }
  std::string file(const std::string& key) const {
    Node n = (*this)[key];
    std::string p = n.string();
    if (p.empty()) n.fail("must not be empty");
    // The system cuts a name at its first NUL ("good.png\u0000x" would open good.png).
    if (p.find('\0') != std::string::npos)
      n.fail("holds a NUL character at position " + std::to_string(p.find('\0')) + ": not a file name");
    return ctx.resolve(p);
  }
};

// Runs f, re-throwing an engine error from a file it reads as "<scene>: <where>: <error>".
template <class F>
auto with_context(const Node& n, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const Error& e) {
    n.ctx.fail(n.path + ":", e.what());
  }
}

}  // namespace ptir::json_node
