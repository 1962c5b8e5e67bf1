#include "ptir/scene/colmap_model.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>
#include <sstream>

#include "ptir/core/error.h"
#include "ptir/io/input_file.h"

namespace ptir {

namespace fs = std::filesystem;

namespace {

constexpr uint64_t kMaxModelBytes = uint64_t(4) << 30;  // a model of millions of points with tracks

// Little-endian binary reader over a whole file (COLMAP writes little-endian).
class BinReader {
 public:
  explicit BinReader(const std::string& path) : path_(path) {
    const std::string bytes = io::read_input_file(path, "COLMAP model file", kMaxModelBytes);
    data_.assign(bytes.begin(), bytes.end());
  }
  template <typename T>
  T get(const char* what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string cstring(const char* what) {
    size_t end = pos_;
    while (end < data_.size() && data_[end] != '\0') ++end;
    if (end >= data_.size()) throw Error(path_, std::string("truncated file (in ") + what + ")");
    std::string s(data_.data() + pos_, end - pos_);
    pos_ = end + 1;
    return s;
  }
  void skip(size_t bytes, const char* what) {
    need(bytes, what);
    pos_ += bytes;
  }
  // A count read from the file, checked against the bytes left (each item >= item_bytes).
  uint64_t count(size_t item_bytes, const char* what) {
    const uint64_t n = get<uint64_t>(what);
    if (item_bytes > 0 && n > (data_.size() - pos_) / item_bytes)
      throw Error(path_, std::string("truncated file or corrupt count ") + std::to_string(n) + " (" + what + ")");
    return n;
  }
  bool at_end() const { return pos_ == data_.size(); }
  // Trailing bytes after the last record are a corrupt (or concatenated) file.
  void expect_end(const char* what) const {
    if (!at_end())
      throw Error(path_, std::to_string(data_.size() - pos_) + " bytes of trailing junk after the last " + what);
  }

 private:
  void need(size_t n, const char* what) {
    if (data_.size() - pos_ < n) throw Error(path_, std::string("truncated file (in ") + what + ")");
  }
  std::string path_;
  std::vector<char> data_;
  size_t pos_ = 0;
};

// Non-comment, non-empty lines of a COLMAP text file with their line numbers.
// images.txt has a second line per image that may be empty: keep_empty keeps those.
std::vector<std::pair<int, std::string>> text_lines(const std::string& path, bool keep_empty) {
  std::istringstream in(io::read_input_file(path, "COLMAP model file", kMaxModelBytes));
  std::vector<std::pair<int, std::string>> lines;
  std::string line;
  int no = 0;
  while (std::getline(in, line)) {
    ++no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first != std::string::npos && line[first] == '#') continue;
    if (first == std::string::npos && !keep_empty) continue;
    lines.emplace_back(no, line);
  }
  return lines;
}

[[noreturn]] void bad_line(const std::string& path, int no, const std::string& what) {
  throw Error(path, "line " + std::to_string(no) + ": " + what);
}

// Nothing but blanks left on a text line (a stream that stopped early on junk is an error).
void expect_line_end(std::istringstream& s, const std::string& path, int no, const std::string& what) {
  if (s.fail() && !s.eof()) s.clear();
  std::string rest;
  if (s >> rest) bad_line(path, no, "unexpected '" + rest.substr(0, 40) + "' after " + what);
}

void check_camera(const ColmapCamera& c, const std::string& path, const std::string& where) {
  if (c.width < 1 || c.height < 1 || c.width > 65536 || c.height > 65536)
    throw Error(path, where + "camera " + std::to_string(c.id) + ": size " + std::to_string(c.width) + "x" +
                          std::to_string(c.height) + " outside 1..65536");
  for (double v : c.params)
    if (!std::isfinite(v)) throw Error(path, where + "camera " + std::to_string(c.id) + ": a parameter is not finite");
}

void check_pose(const ColmapImage& im, const std::string& path, const std::string& where) {
  double qn = 0.0;
  for (double v : im.q) qn += v * v;
  for (double v : im.t) qn += std::isfinite(v) ? 0.0 : NAN;
  if (!std::isfinite(qn) || qn < 1e-12)
    throw Error(path, where + "image " + std::to_string(im.id) + " (" + im.name +
                          "): its quaternion is zero or a pose value is not finite");
}

std::string pick(const std::string& dir, const std::string& stem, bool& binary) {
  const fs::path b = fs::path(dir) / (stem + ".bin"), t = fs::path(dir) / (stem + ".txt");
  if (fs::exists(b)) {
    binary = true;
    return b.string();
  }
  if (fs::exists(t)) {
    binary = false;
    return t.string();
  }
  throw Error(dir, "COLMAP model has no " + stem + ".bin or " + stem + ".txt");
}

void read_cameras(ColmapModel& m, bool binary) {
  const std::string& p = m.cameras_path;
  if (binary) {
    BinReader r(p);
    const uint64_t n = r.count(24, "camera count");
    for (uint64_t i = 0; i < n; ++i) {
      ColmapCamera c;
      c.id = r.get<uint32_t>("camera id");
      const int model_id = r.get<int32_t>("camera model");
      c.model = colmap_model_name(model_id);
      if (c.model.empty()) throw Error(p, "camera " + std::to_string(c.id) + ": unknown model id " + std::to_string(model_id));
      const uint64_t w = r.get<uint64_t>("camera width"), h = r.get<uint64_t>("camera height");
      c.width = int(std::min<uint64_t>(w, 1u << 30));
      c.height = int(std::min<uint64_t>(h, 1u << 30));
      c.params.resize(size_t(colmap_model_param_count(c.model)));
      for (double& v : c.params) v = r.get<double>("camera parameters");
      check_camera(c, p, "");
      if (!m.cameras.emplace(c.id, c).second) throw Error(p, "camera id " + std::to_string(c.id) + " appears twice");
    }
    r.expect_end("camera");
    return;
  }
  for (const auto& [no, line] : text_lines(p, false)) {
    std::istringstream s(line);
    ColmapCamera c;
    if (!(s >> c.id >> c.model >> c.width >> c.height)) bad_line(p, no, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    double v;
    while (s >> v) c.params.push_back(v);
    expect_line_end(s, p, no, "the camera parameters");
    const int expect = colmap_model_param_count(c.model);
    if (expect < 0) bad_line(p, no, "unknown camera model '" + c.model + "'");
    if (int(c.params.size()) != expect)
      bad_line(p, no, c.model + " needs " + std::to_string(expect) + " parameters, got " + std::to_string(c.params.size()));
    check_camera(c, p, "line " + std::to_string(no) + ": ");
    if (!m.cameras.emplace(c.id, c).second) bad_line(p, no, "camera id " + std::to_string(c.id) + " appears twice");
  }
}

// Image ids and names are unique (a duplicate is a merged or corrupt model).
void check_unique_images(const ColmapModel& m) {
  std::set<uint32_t> ids;
  std::set<std::string> names;
  for (const ColmapImage& im : m.images) {
    if (!ids.insert(im.id).second) throw Error(m.images_path, "image id " + std::to_string(im.id) + " appears twice");
    if (!names.insert(im.name).second) throw Error(m.images_path, "image name '" + im.name + "' appears twice");
  }
}

void read_images(ColmapModel& m, bool binary, bool with_obs) {
  const std::string& p = m.images_path;
  if (binary) {
    BinReader r(p);
    const uint64_t n = r.count(64, "image count");
    for (uint64_t i = 0; i < n; ++i) {
      ColmapImage im;
      im.id = r.get<uint32_t>("image id");
      for (double& v : im.q) v = r.get<double>("image quaternion");
      for (double& v : im.t) v = r.get<double>("image translation");
      im.camera_id = r.get<uint32_t>("image camera id");
      im.name = r.cstring("image name");
      const uint64_t np = r.count(24, "2D point count");
      if (!with_obs) {
        r.skip(size_t(np) * 24, "2D points");
      } else {
        im.xy.resize(np);
        im.point3d_id.resize(np);
        for (uint64_t k = 0; k < np; ++k) {
          im.xy[k][0] = r.get<double>("2D point");
          im.xy[k][1] = r.get<double>("2D point");
          im.point3d_id[k] = r.get<int64_t>("2D point's 3D id");
        }
      }
      check_pose(im, p, "");
      m.images.push_back(std::move(im));
    }
    r.expect_end("image");
    check_unique_images(m);
    return;
  }
  const auto lines = text_lines(p, true);
  size_t i = 0;
  while (i < lines.size()) {
    const auto& [no, line] = lines[i];
    if (line.find_first_not_of(" \t") == std::string::npos) {
      ++i;  // blank line between records (or a trailing one)
      continue;
    }
    std::istringstream s(line);
    ColmapImage im;
    if (!(s >> im.id >> im.q[0] >> im.q[1] >> im.q[2] >> im.q[3] >> im.t[0] >> im.t[1] >> im.t[2] >> im.camera_id))
      bad_line(p, no, "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    std::getline(s >> std::ws, im.name);
    while (!im.name.empty() && (im.name.back() == ' ' || im.name.back() == '\t')) im.name.pop_back();
    if (im.name.empty()) bad_line(p, no, "image " + std::to_string(im.id) + " has no name");
    check_pose(im, p, "line " + std::to_string(no) + ": ");
    ++i;
    if (i < lines.size()) {  // the 2D points line (possibly empty)
      const auto& [no2, pts] = lines[i];
      if (with_obs) {
        std::istringstream ps(pts);
        double x, y;
        int64_t id;
        while (ps >> x >> y >> id) {
          im.xy.push_back({x, y});
          im.point3d_id.push_back(id);
        }
        if (!ps.eof()) bad_line(p, no2, "expected POINTS2D[] as (X, Y, POINT3D_ID)");
      }
      ++i;
    }
    m.images.push_back(std::move(im));
  }
  check_unique_images(m);
}

void read_points(ColmapModel& m, bool binary) {
  const std::string& p = m.points_path;
  if (binary) {
    BinReader r(p);
    const uint64_t n = r.count(51, "point count");
    m.points.resize(n);
    for (uint64_t i = 0; i < n; ++i) {
      ColmapPoint& pt = m.points[i];
      pt.id = r.get<uint64_t>("point id");
      for (double& v : pt.xyz) v = r.get<double>("point position");
      for (uint8_t& v : pt.rgb) v = r.get<uint8_t>("point colour");
      pt.error = r.get<double>("point error");
      const uint64_t nt = r.count(8, "track length");
      pt.track.resize(nt);
      for (auto& e : pt.track) {
        e.first = r.get<uint32_t>("track image id");
        e.second = r.get<uint32_t>("track 2D point index");
      }
    }
    r.expect_end("point");
    std::set<uint64_t> ids;
    for (const ColmapPoint& pt : m.points)
      if (!ids.insert(pt.id).second) throw Error(p, "point id " + std::to_string(pt.id) + " appears twice");
    return;
  }
  std::set<uint64_t> ids;
  for (const auto& [no, line] : text_lines(p, false)) {
    std::istringstream s(line);
    ColmapPoint pt;
    int rgb[3];
    if (!(s >> pt.id >> pt.xyz[0] >> pt.xyz[1] >> pt.xyz[2] >> rgb[0] >> rgb[1] >> rgb[2] >> pt.error))
      bad_line(p, no, "expected POINT3D_ID X Y Z R G B ERROR TRACK[]");
    for (int c = 0; c < 3; ++c) pt.rgb[size_t(c)] = uint8_t(rgb[c]);
    uint32_t a, b;
    while (s >> a >> b) pt.track.emplace_back(a, b);
    expect_line_end(s, p, no, "the track");
    if (!ids.insert(pt.id).second) bad_line(p, no, "point id " + std::to_string(pt.id) + " appears twice");
    m.points.push_back(std::move(pt));
  }
}

}  // namespace

std::string find_colmap_model(const std::string& root) {
  for (const fs::path& d : {fs::path(root) / "sparse" / "0", fs::path(root) / "sparse", fs::path(root)})
    if (fs::exists(d / "cameras.bin") || fs::exists(d / "cameras.txt")) return d.lexically_normal().string();
  return "";
}

ColmapModel read_colmap_model(const std::string& dir, bool with_observations, bool with_points) {
  ColmapModel m;
  m.dir = dir;
  bool cb = true, ib = true, pb = true;
  m.cameras_path = pick(dir, "cameras", cb);
  m.images_path = pick(dir, "images", ib);
  read_cameras(m, cb);
  read_images(m, ib, with_observations);
  m.binary = cb && ib;
  for (const ColmapImage& im : m.images)
    if (!m.cameras.count(im.camera_id))
      throw Error(m.images_path, "image " + std::to_string(im.id) + " (" + im.name + ") refers to camera " +
                                     std::to_string(im.camera_id) + ", which " + m.cameras_path + " does not have");
  if (with_points) {
    m.points_path = pick(dir, "points3D", pb);
    read_points(m, pb);
  }
  return m;
}

std::array<double, 9> colmap_rotation(const std::array<double, 4>& q_in) {
  const double n = std::sqrt(q_in[0] * q_in[0] + q_in[1] * q_in[1] + q_in[2] * q_in[2] + q_in[3] * q_in[3]);
  const double w = q_in[0] / n, x = q_in[1] / n, y = q_in[2] / n, z = q_in[3] / n;
  return {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
          2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
          2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
}

}  // namespace ptir
