#include "serve_session.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <vector>

#include "image_budget.h"
#include "output_guard.h"
#include "serve_requests.h"
#include "ptir/core/error.h"
#include "ptir/io/input_file.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/image.h"
#include "ptir/material/material_range.h"
#include "ptir/render/aov.h"
#include "ptir/render/render_path.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/mesh_tangents.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/orient_normals.h"

namespace ptir::cli {

namespace {

using json = nlohmann::json;
using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

const json& require(const json& request, const char* key) {
  if (!request.contains(key)) throw Error(std::string("request needs \"") + key + "\"");
  return request.at(key);
}

std::string string_of(const json& request, const char* key) {
  const json& v = require(request, key);
  if (!v.is_string()) throw Error(std::string("request: \"") + key + "\" must be a string");
  return v.get<std::string>();
}

int64_t integer_of(const json& request, const char* key, int64_t fallback, int64_t lo, int64_t hi) {
  if (!request.contains(key)) return fallback;
  const json& v = request.at(key);
  if (!v.is_number_integer() || v.get<int64_t>() < lo || v.get<int64_t>() > hi)
    throw Error(std::string("request: \"") + key + "\" must be an integer in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "]");
  return v.get<int64_t>();
}

// A finite number that fits a float (1e39 would become +inf).
float number_of(const json& request, const char* key) {
  const json& v = require(request, key);
  const double d = v.is_number() ? v.get<double>() : 0.0;
  if (!v.is_number() || !std::isfinite(d) || std::fabs(d) > 3.0e38)
    throw Error(std::string("request: \"") + key + "\" must be a finite number");
  return float(d);
}

bool boolean_of(const json& request, const char* key, bool fallback) {
  if (!request.contains(key)) return fallback;
  if (!request.at(key).is_boolean()) throw Error(std::string("request: \"") + key + "\" must be true or false");
  return request.at(key).get<bool>();
}

// 16 finite numbers (a row-major 4x4 matrix).
void matrix_of(const json& m, const char* what, float out[16]) {
  const std::string message = std::string("request: ") + what + " must hold 16 finite numbers (row-major)";
  if (!m.is_array() || m.size() != 16) throw Error(message);
  for (size_t i = 0; i < 16; ++i) {
    const json& x = m.at(i);
    const double d = x.is_number() ? x.get<double>() : 0.0;
    if (!x.is_number() || !std::isfinite(d) || std::fabs(d) > 3.0e38) throw Error(message);
    out[i] = float(d);
  }
}

// A scene document of the given parts, read by the scene-file reader (one
// parser for files and edits: the same checks and messages).
Scene parse_parts(const json& parts, const std::string& base_dir) {
  return scene_from_json_string(parts.dump(), base_dir, "request");
}

size_t triangle_count(const Scene& s) {
  size_t n = 0;
  for (const TriangleMesh& m : s.meshes) n += m.triangles.size();
  return n;
}

// "view": a pinhole from the viewport's matrices (any principal point: the 3D
// view's camera frame can be off-centre), sized as the request asks.
Camera view_camera(const json& v) {
  if (!v.is_object()) throw Error("request: \"view\" must be an object (c2w, fx, fy, cx, cy, width, height)");
  check_keys(v, "view", {"c2w", "fx", "fy", "cx", "cy", "width", "height"});
  float c2w[16];
  matrix_of(require(v, "c2w"), "view.c2w", c2w);
  const int w = int(integer_of(v, "width", 0, 1, 16384)), h = int(integer_of(v, "height", 0, 1, 16384));
  if (w == 0 || h == 0) throw Error("request: view needs width and height");
  return make_pinhole_camera(c2w, number_of(v, "fx"), number_of(v, "fy"), number_of(v, "cx"), number_of(v, "cy"), w, h,
                             "view");
}

// The render's camera: a scene-file camera object ("camera", parsed as the CLI
// parses the file), a camera of the loaded scene by name ("camera_name"), or the
// viewport's ("view").
Camera request_camera(const json& request, const Scene& scene, const std::string& base_dir) {
  if (request.contains("view")) return view_camera(request.at("view"));
  if (request.contains("camera")) {
    Scene part = parse_parts(json{{"cameras", json::array({request.at("camera")})}}, base_dir);
    return part.cameras.at(0);
  }
  return scene.camera(request.contains("camera_name") ? string_of(request, "camera_name") : "");
}

// Raw float32 RGBA, top row first, no header (the viewport reads it with numpy).
void write_raw(const std::string& path, const Image& image) {
  io::write_bytes_atomic(path, image.pixels.data(), image.pixels.size() * sizeof(float));
}

bool ends_with_exr(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".exr";
}

std::vector<float> read_floats(const std::string& path, size_t count) {
  const uint64_t size = io::check_regular_file(path, "bulk file");  // a FIFO or /dev/zero would block or grow
  if (size != count * sizeof(float))
    throw Error(path, "holds " + std::to_string(size) + " bytes, expected " + std::to_string(count * sizeof(float)));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open");
  std::vector<float> v(count);
  in.read(reinterpret_cast<char*>(v.data()), std::streamsize(count * sizeof(float)));
  if (size_t(in.gcount()) != count * sizeof(float))
    throw Error(path, "holds " + std::to_string(in.gcount()) + " bytes, expected " + std::to_string(count * sizeof(float)));
  return v;
}

// A whole file of uint32 little-endian values (splat indices).
std::vector<uint32_t> read_indices(const std::string& path, uint64_t max_count) {
  const uint64_t bytes = io::check_regular_file(path, "index file");
  if (bytes > max_count * 4)
    throw Error(path, "holds " + std::to_string(bytes / 4) + " indices, more than the " + std::to_string(max_count) +
                          " Gaussians of the range");
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw Error(path, "cannot open");
  const std::streamoff size = in.tellg();
  if (size % 4 != 0) throw Error(path, "holds " + std::to_string(size) + " bytes, not a whole number of uint32 indices");
  std::vector<uint32_t> v(size_t(size / 4));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(v.data()), size);
  if (in.gcount() != size) throw Error(path, "cannot read " + std::to_string(size) + " bytes");
  return v;
}

// build_s split as the accel layer measured it (accel/scene_accel.h: AccelBuildTimes).
json build_parts(const PathTracer& tracer) {
  const AccelBuildTimes& t = tracer.accel().build_times();
  return {{"trace_data_s", t.trace_data}, {"boxes_s", t.boxes}, {"bvh_s", t.bvh}};
}

}  // namespace

ServeSession::ServeSession(ServeLimits limits, const std::string& out_dir) : limits_(limits) {
  namespace fs = std::filesystem;
  const fs::path root = out_dir.empty() ? fs::current_path() : fs::path(out_dir);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) throw Error(root.string(), "serve --out: not a folder");
  out_root_ = fs::canonical(root);
}

const PathTracer& ServeSession::tracer() const {
  if (!tracer_) throw Error("no scene loaded (send \"load\" first)");
  return *tracer_;
}

json ServeSession::handle(const json& request, const std::atomic<bool>* cancel,
                          const std::function<void(const json&)>& notify) {
  json reply = {{"ok", true}};
  if (request.contains("id")) reply["id"] = request.at("id");
  const auto t0 = Clock::now();
  uint64_t bytes_in = 0;
  try {
    if (!request.is_object() || !request.contains("cmd") || !request.at("cmd").is_string())
      throw Error("a request is a JSON object with a \"cmd\" string");
    const std::string cmd = request.at("cmd").get<std::string>();
    if (cmd == "load") check_keys(request, cmd, {"scene"});
    else if (cmd == "update") check_keys(request, cmd, {"scene", "base_dir"});
    else if (cmd == "mesh_material") check_keys(request, cmd, {"mesh", "material"});
    else if (cmd == "splat_materials") check_keys(request, cmd, {"offset", "count", "file", "channels", "indices"});
    else if (cmd == "transform_splats") check_keys(request, cmd, {"offset", "count", "matrix"});
    else if (cmd == "render")
      check_keys(request, cmd, {"camera", "camera_name", "view", "output", "spp", "first_sample", "width", "height",
                                "transparent", "aovs"});
    else if (cmd == "status") check_keys(request, cmd, {});
    json out;
    if (cmd == "load") out = load(request);
    else if (cmd == "update") out = update(request);
    else if (cmd == "mesh_material") out = mesh_material(request);
    else if (cmd == "splat_materials") out = splat_materials(request, &bytes_in);
    else if (cmd == "transform_splats") out = transform_splats(request);
    else if (cmd == "render") out = render(request, cancel, notify);
    else if (cmd == "status") out = status();
    else throw Error("unknown request \"" + cmd + "\" (load, update, mesh_material, splat_materials, transform_splats, "
                     "render, status, cancel, quit)");
    reply.update(out);
  } catch (const Cancelled&) {
    reply["ok"] = false;
    reply["cancelled"] = true;
  } catch (const std::exception& e) {
    reply["ok"] = false;
    reply["error"] = e.what();
  }
  reply["seconds"] = seconds_since(t0);
  reply["bulk_bytes_in"] = bytes_in;
  return reply;
}

// Reads the scene file as `ptir render scene.json` does (normals oriented to the
// scene's cameras) and builds the acceleration structure. The old scene stays
// loaded when the new one fails.
json ServeSession::load(const json& request) {
  const std::string path = string_of(request, "scene");
  const auto t0 = Clock::now();
  auto scene = std::make_unique<Scene>(load_scene_json(path));
  orient_scene_normals(*scene);
  const double load_s = seconds_since(t0);
  const auto t1 = Clock::now();
  auto tracer = std::make_unique<PathTracer>(*scene);
  tracer_.reset();
  scene_ = std::move(scene);
  tracer_ = std::move(tracer);
  scene_path_ = path;
  ++builds_;
  json reply = status();
  reply["load_s"] = load_s;
  reply["build_s"] = seconds_since(t1);
  reply["build_parts"] = build_parts(*tracer_);
  return reply;
}

// Lights, world and integrator settings: the parts present replace the loaded
// ones ("environment": null removes the world). Geometry is untouched.
json ServeSession::update(const json& request) {
  tracer();
  const json& parts = require(request, "scene");
  if (!parts.is_object()) throw Error("request: \"scene\" must be an object (scene-file keys)");
  for (auto it = parts.begin(); it != parts.end(); ++it)
    if (it.key() != "lights" && it.key() != "environment" && it.key() != "integrator" && it.key() != "brdf")
      throw Error("request: update takes lights, environment, integrator and brdf; \"" + it.key() +
                  "\" changes geometry (send \"load\")");
  json doc = parts;
  if (doc.contains("environment") && doc["environment"].is_null()) doc.erase("environment");
  const std::string base = std::filesystem::path(scene_path_).parent_path().string();
  Scene part = parse_parts(doc, request.contains("base_dir") ? string_of(request, "base_dir") : base);
  json changed = json::array();
  if (parts.contains("lights")) {
    scene_->emitters = std::move(part.emitters);
    scene_->emitter_visible_camera = std::move(part.emitter_visible_camera);
    changed.push_back("lights");
  }
  if (parts.contains("environment")) {
    scene_->environment = std::move(part.environment);
    changed.push_back("environment");
  }
  if (parts.contains("integrator") || parts.contains("brdf")) {
    const BsdfModel kept = scene_->integrator.brdf;
    scene_->integrator = part.integrator;
    if (!parts.contains("brdf")) scene_->integrator.brdf = kept;  // an integrator update keeps the model
    changed.push_back("integrator");
  }
  return {{"changed", changed}, {"builds", builds_}};
}

// One mesh's material, by the mesh's name in the scene file.
json ServeSession::mesh_material(const json& request) {
  tracer();
  const std::string name = string_of(request, "mesh");
  for (TriangleMesh& m : scene_->meshes)
    if (m.name == name) {
      m.material = mesh_material_from_json_string(require(request, "material").dump(), "request: mesh '" + name + "'");
      prepare_mesh_tangents(m);  // a normal map on a mesh written without tangents
      return {{"builds", builds_}};
    }
  throw Error("request: the loaded scene has no mesh named '" + name + "'");
}

// Per-splat material values of Gaussians [offset, offset + count): the file holds,
// for each of "channels" in the order given (default albedo, roughness, metallic),
// the values of the addressed Gaussians (albedo 3 floats each, the others 1):
// all `count` of them, or with "indices" (a file of uint32, relative to offset)
// only those. An edit of a few splats, or of the albedo alone, sends only that.
json ServeSession::splat_materials(const json& request, uint64_t* bytes_in) {
  tracer();
  GaussianField& f = *scene_->gaussians;
  const int64_t offset = integer_of(request, "offset", 0, 0, int64_t(f.size()));
  const int64_t count = integer_of(request, "count", int64_t(f.size()) - offset, 0, int64_t(f.size()) - offset);
  std::vector<std::string> channels = {"albedo", "roughness", "metallic"};
  if (request.contains("channels")) {
    const json& c = request.at("channels");
    if (!c.is_array() || c.empty()) throw Error("request: \"channels\" must be a non-empty array of channel names");
    channels.clear();
    for (const json& name : c) {
      if (!name.is_string() || (name != "albedo" && name != "roughness" && name != "metallic"))
        throw Error("request: unknown channel " + name.dump() + " (albedo, roughness, metallic)");
      channels.push_back(name.get<std::string>());
    }
  }
  std::vector<uint32_t> indices;
  if (request.contains("indices")) {
    const std::string path = string_of(request, "indices");
    indices = read_indices(path, uint64_t(count));
    for (uint32_t i : indices)
      if (int64_t(i) >= count)
        throw Error(path, "index " + std::to_string(i) + " outside the range of " + std::to_string(count) + " Gaussians");
    *bytes_in += indices.size() * sizeof(uint32_t);
  }
  const size_t n = request.contains("indices") ? indices.size() : size_t(count);
  size_t width = 0;
  for (const std::string& c : channels) width += c == "albedo" ? 3 : 1;
  const std::string file = string_of(request, "file");
  std::vector<float> v = read_floats(file, n * width);
  *bytes_in += v.size() * sizeof(float);
  auto target = [&](size_t i) { return size_t(offset) + (indices.empty() ? i : size_t(indices[i])); };
  const float* p = v.data();
  for (const std::string& c : channels)  // the PLY reader's rule (material_range.h): NaN pixels otherwise
    for (size_t i = 0; i < n; ++i)
      for (int k = 0; k < (c == "albedo" ? 3 : 1); ++k, ++p)
        check_material_value(*p, file, c == "albedo" ? "albedo_" + std::to_string(k) : c, target(i));
  p = v.data();
  for (const std::string& c : channels) {  // (all values are read and checked before any is written)
    if (c == "albedo")
      for (size_t i = 0; i < n; ++i, p += 3) f.albedo[target(i)] = Vec3(p[0], p[1], p[2]);
    else {
      std::vector<float>& dst = c == "roughness" ? f.roughness : f.metallic;
      for (size_t i = 0; i < n; ++i, ++p) dst[target(i)] = *p;
    }
  }
  return {{"builds", builds_}, {"splats", n}};
}

// Gaussians [offset, offset + count) moved by a row-major 4x4 similarity (the
// rule of a scene file's "transform": transform_gaussians), then the acceleration
// structure rebuilt. The add-on sends an object's new world matrix times the
// inverse of the old one.
json ServeSession::transform_splats(const json& request) {
  tracer();
  GaussianField& f = *scene_->gaussians;
  const size_t offset = size_t(integer_of(request, "offset", 0, 0, int64_t(f.size())));
  const size_t count = size_t(integer_of(request, "count", 0, 0, int64_t(f.size() - offset)));
  float mat[16];
  matrix_of(require(request, "matrix"), "\"matrix\"", mat);
  GaussianField part;  // the range's geometry (what transform_gaussians changes)
  const auto first = std::ptrdiff_t(offset), last = std::ptrdiff_t(offset + count);
  part.position.assign(f.position.begin() + first, f.position.begin() + last);
  part.scale.assign(f.scale.begin() + first, f.scale.begin() + last);
  part.rotation.assign(f.rotation.begin() + first, f.rotation.begin() + last);
  part.normal.assign(f.normal.begin() + first, f.normal.begin() + last);
  transform_gaussians(part, mat, "request: transform_splats");
  std::copy(part.position.begin(), part.position.end(), f.position.begin() + first);
  std::copy(part.scale.begin(), part.scale.end(), f.scale.begin() + first);
  std::copy(part.rotation.begin(), part.rotation.end(), f.rotation.begin() + first);
  std::copy(part.normal.begin(), part.normal.end(), f.normal.begin() + first);
  f.source = io::PlyFile();
  const auto t0 = Clock::now();
  tracer_ = std::make_unique<PathTracer>(*scene_);
  ++builds_;
  return {{"builds", builds_}, {"build_s", seconds_since(t0)}, {"build_parts", build_parts(*tracer_)}};
}

// Path-traced colour, exactly as `ptir render` computes it for the same camera
// and settings; "first_sample" starts a progressive pass further along the
// pixels' sample sequence. Optional AOVs (1 spp, pixel centres, as the CLI's default).
json ServeSession::render(const json& request, const std::atomic<bool>* cancel,
                          const std::function<void(const json&)>& notify) {
  const PathTracer& pt = tracer();
  const std::string base = std::filesystem::path(scene_path_).parent_path().string();
  Camera camera = request_camera(request, *scene_, base);
  if (request.contains("width") || request.contains("height")) {
    const int w = int(integer_of(request, "width", camera.width, 1, 16384));
    const int h = int(integer_of(request, "height", camera.height, 1, 16384));
    camera = camera.resized(w, h);
  }
  IntegratorSettings settings = scene_->integrator;
  settings.spp = int(integer_of(request, "spp", settings.spp, 1, 1 << 20));
  const uint32_t first = uint32_t(integer_of(request, "first_sample", 0, 0, (1 << 24) - (1 << 20)));
  const bool transparent = boolean_of(request, "transparent", false);
  const std::string output = string_of(request, "output");
  check_size(camera, settings.spp);
  std::vector<std::string> outputs = {output};
  if (request.contains("aovs")) {
    const json& aovs = request.at("aovs");
    if (!aovs.is_object()) throw Error("request: \"aovs\" must map AOV names to output files");
    for (auto it = aovs.begin(); it != aovs.end(); ++it) {
      parse_aov(it.key());
      if (!it.value().is_string()) throw Error("request: aovs." + it.key() + " must be a file name");
      outputs.push_back(it.value().get<std::string>());
    }
  }
  outputs = guard_request_outputs(outputs);  // before the render: a refused output costs nothing
  RenderControl control;
  control.cancel = cancel;
  // Progress lines at most 4 times a second (render_path calls this under its lock).
  auto last = Clock::now();
  if (notify && request.contains("id"))
    control.progress = [&](float f) {
      if (f < 1.0f && std::chrono::duration<double>(Clock::now() - last).count() < 0.25) return;
      last = Clock::now();
      notify({{"id", request.at("id")}, {"progress", f}});
    };
  PathStats stats;
  Image image = render_path(pt, camera, settings, control, &stats, nullptr, transparent, first);
  set_film_alpha(image, transparent, scene_->environment.present());  // as `ptir render` writes it
  write_output(outputs[0], image, Encoding::Colour);
  json reply = {{"width", camera.width}, {"height", camera.height}, {"spp", settings.spp}, {"first_sample", first},
                {"paths", stats.paths}, {"bytes_out", image.pixels.size() * sizeof(float)}};
  if (request.contains("aovs")) {
    const json& aovs = request.at("aovs");
    if (!aovs.is_object()) throw Error("request: \"aovs\" must map AOV names to output files");
    AovSettings as;
    as.seed = settings.seed;
    as.filter = settings.filter;
    as.interaction = settings.interaction;
    size_t k = 1;  // outputs[k]: this AOV's file (in the order of "aovs")
    for (auto it = aovs.begin(); it != aovs.end(); ++it, ++k) {
      const Aov aov = parse_aov(it.key());
      Image a = render_aov(pt.accel(), camera, aov, as, control);
      write_output(outputs[k], a, aov_encoding(aov));
      reply["aov_channels"][it.key()] = a.channels;
    }
  }
  return reply;
}

// The render's image under `ptir render`'s memory budget, and its samples under
// the session's limit.
void ServeSession::check_size(const Camera& camera, int spp) const {
  check_image_budget(camera.width, camera.height, limits_.max_memory_gib, "request: render");
  const uint64_t samples = uint64_t(camera.width) * uint64_t(camera.height) * uint64_t(spp);
  if (limits_.max_samples > 0 && samples > limits_.max_samples)
    throw Error("request: render: " + std::to_string(samples) + " samples, more than this session's limit of " +
                std::to_string(limits_.max_samples));
}

// The rule of every command (output_guard.h): no output over the loaded scene's
// files (the scene file and every file it names), nor over anything but a
// regular file; then the session's own (serve_session.h): under the output
// folder, and no existing file but one this session wrote. Returns the paths to
// write (links resolved).
std::vector<std::string> ServeSession::guard_request_outputs(const std::vector<std::string>& outputs) const {
  namespace fs = std::filesystem;
  std::vector<std::string> resolved;
  for (const std::string& out : outputs) {
    if (out.empty()) throw Error("request: an output file name is empty");
    if (out.find('\0') != std::string::npos) throw Error("request: an output file name holds a NUL character");
    const fs::path full = fs::path(out).is_absolute() ? fs::path(out) : out_root_ / out;
    std::error_code ec;
    if (fs::exists(full, ec) && !fs::is_regular_file(full, ec))
      throw Error(out, "exists and is not a regular file; refusing to write over it");
    resolved.push_back(fs::weakly_canonical(full, ec).string());
    if (ec) throw Error(out, "cannot resolve the output path: " + ec.message());
  }
  Inputs in;
  if (!scene_path_.empty()) in.scenes.push_back(scene_path_);
  Outputs out;
  out.files = resolved;
  guard_outputs(in, out, /*force=*/false);
  for (size_t i = 0; i < resolved.size(); ++i) {
    const fs::path p(resolved[i]);
    const auto rel = p.lexically_relative(out_root_);
    if (rel.empty() || *rel.begin() == ".." || rel == ".")
      throw Error(outputs[i], "is outside this session's output folder " + out_root_.string() +
                                  " (serve --out): refusing to write it");
    std::error_code ec;
    if (fs::exists(p, ec) && !written_.count(resolved[i]))
      throw Error(outputs[i], "exists and was not written by this session: refusing to replace it");
  }
  return resolved;
}

// An output (resolved by guard_request_outputs): EXR by extension, else raw floats.
void ServeSession::write_output(const std::string& path, const Image& image, Encoding encoding) {
  if (ends_with_exr(path)) write_image(path, image, encoding);
  else write_raw(path, image);
  written_.insert(path);
}

json ServeSession::status() const {
  json s = {{"loaded", bool(tracer_)}, {"builds", builds_}};
  if (scene_) {
    s["scene"] = scene_path_;
    s["gaussians"] = scene_->gaussians->size();
    s["triangles"] = triangle_count(*scene_);
    s["meshes"] = scene_->meshes.size();
    s["lights"] = scene_->emitters.size();
  }
  return s;
}

}  // namespace ptir::cli
