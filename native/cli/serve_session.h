// `ptir serve`: a persistent engine holding one loaded scene (Gaussians, meshes,
// lights, world, acceleration structure) and answering requests, one JSON object
// per line (the protocol: docs/engine_protocol.md). The Blender add-on keeps one
// such child process per session for its viewport and F12 renders.
//
// What a request costs: "update" (lights, world, integrator), "mesh_material" and
// "splat_materials" change the loaded scene in place (the acceleration structure
// holds geometry only, so it is kept); "load" reads a scene file and rebuilds
// everything (geometry changed). Bulk data (splat attributes, images) travels in
// files the request names, never inside the JSON line.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <unordered_set>
#include <vector>

#include <nlohmann/json.hpp>

#include "ptir/io/image.h"
#include "ptir/scene/scene.h"
#include "ptir/transport/path_tracer.h"

namespace ptir::cli {

// What one request may cost. max_memory_gib: the image budget of `ptir render`
// (image_budget.h; 0: half the machine's memory); max_samples: pixels x spp of
// one render (0: no limit; the fuzz harness keeps its renders small).
struct ServeLimits {
  double max_memory_gib = 0.0;
  uint64_t max_samples = 0;
};

// Where a session writes (docs/engine_protocol.md): only under `out_dir`, the
// folder its client gives at start (`serve --out`; the add-on's session folder;
// empty: the working directory). A relative output name is taken in it; an
// absolute one, or one whose ".." or links lead out of it, is refused; and an
// existing file is replaced only when this session wrote it.
class ServeSession {
 public:
  explicit ServeSession(ServeLimits limits = {}, const std::string& out_dir = "");

  // Answers one request (never throws: errors become {"ok": false, "error": ...}).
  // cancel: raised by the request reader while this request runs (a "cancel" line).
  // notify: sends an interim line (render progress: {"id": ..., "progress": f}).
  nlohmann::json handle(const nlohmann::json& request, const std::atomic<bool>* cancel,
                        const std::function<void(const nlohmann::json&)>& notify = {});

 private:
  nlohmann::json load(const nlohmann::json& request);
  nlohmann::json update(const nlohmann::json& request);
  nlohmann::json mesh_material(const nlohmann::json& request);
  nlohmann::json splat_materials(const nlohmann::json& request, uint64_t* bytes_in);
  nlohmann::json transform_splats(const nlohmann::json& request);
  nlohmann::json render(const nlohmann::json& request, const std::atomic<bool>* cancel,
                        const std::function<void(const nlohmann::json&)>& notify);
  nlohmann::json status() const;
  const PathTracer& tracer() const;

  void check_size(const Camera& camera, int spp) const;
  std::vector<std::string> guard_request_outputs(const std::vector<std::string>& outputs) const;
  void write_output(const std::string& path, const Image& image, Encoding encoding);

  ServeLimits limits_;
  std::unique_ptr<Scene> scene_;
  std::unique_ptr<PathTracer> tracer_;
  std::string scene_path_;
  uint64_t builds_ = 0;  // acceleration structures built (one per load)
  std::filesystem::path out_root_;           // the output folder, links resolved
  std::unordered_set<std::string> written_;  // the files this session wrote (resolved paths)
};

}  // namespace ptir::cli
