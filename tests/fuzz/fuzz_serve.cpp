// The engine protocol (native/cli/serve_requests.cpp, serve_session.cpp): the
// input is request lines, each parsed and answered by a fresh session holding a
// tiny loaded scene (9 Gaussians, a point light, a 16x16 camera), exactly as
// `ptir serve` answers stdin. Every reply must be dumpable (a reply is a line).
// Confinement: the harness works in its scratch folder and skips lines holding
// '/' (no file outside it is read or written); renders are capped at 4096
// samples and 0.25 GiB. Seeds: tests/fuzz/corpus/serve/.
#include <unistd.h>

#include <atomic>
#include <set>
#include <sstream>

#include "fuzz_common.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/json_limits.h"
#include "serve_requests.h"
#include "serve_session.h"

namespace {

namespace fs = std::filesystem;

const std::set<std::string>& scene_files() {
  static const std::set<std::string> names = [] {
    const fs::path dir = ptir_fuzz::scratch() / "serve";
    fs::create_directories(dir);
    ptir::GaussianField f;
    for (int i = 0; i < 9; ++i) {
      f.position.push_back(ptir::Vec3(0.3f * float(i % 3) - 0.3f, 0.3f * float(i / 3) - 0.3f, -2.0f));
      f.scale.push_back(ptir::Vec3(0.2f, 0.2f, 0.002f));
      f.rotation.push_back({1.0f, 0.0f, 0.0f, 0.0f});
      f.opacity.push_back(0.9f);
      f.albedo.push_back(ptir::Vec3(0.6f, 0.4f, 0.2f));
      f.roughness.push_back(0.5f);
      f.metallic.push_back(0.0f);
    }
    f.sh.assign(9 * 3, 0.5f);
    f.normal.assign(9, ptir::Vec3(0.0f, 0.0f, 1.0f));
    ptir::save_gaussians((dir / "wall.ply").string(), f);
    ptir_fuzz::write_file(dir / "scene.json", std::string(R"({"gaussians": [{"file": "wall.ply"}],
      "lights": [{"type": "point", "position": [0, 0, 0], "power": 100}],
      "cameras": [{"name": "cam", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "fov_x": 0.9,
                   "width": 16, "height": 16}],
      "integrator": {"spp": 1, "bounces": 1}})"));
    float m[20 * 9];
    for (float& v : m) v = 0.5f;
    ptir_fuzz::write_file(dir / "mat.f32", reinterpret_cast<const uint8_t*>(m), sizeof m);
    if (::chdir(dir.c_str()) != 0) std::abort();
    return std::set<std::string>{"wall.ply", "scene.json", "mat.f32"};
  }();
  return names;
}

void remove_outputs() {
  std::error_code ec;
  for (fs::directory_iterator it(".", ec), end; !ec && it != end; it.increment(ec))
    if (!scene_files().count(it->path().filename().string())) fs::remove_all(it->path(), ec);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  scene_files();
  const std::string input(reinterpret_cast<const char*>(data), size);
  if (input.find('/') != std::string::npos) return 0;  // confinement (see above)
  ptir::cli::ServeSession session(ptir::cli::ServeLimits{0.25, 4096});
  std::atomic<bool> cancel{false};
  auto sink = [](const nlohmann::json& j) { ptir::dump_json_safe(j); };
  session.handle({{"cmd", "load"}, {"scene", "scene.json"}}, &cancel);
  std::istringstream lines(input);
  std::string line;
  while (std::getline(lines, line)) {
    ptir::cli::RequestLine r = ptir::cli::parse_request_line(line);
    nlohmann::json reply;
    if (r.ok()) reply = session.handle(r.request, &cancel, sink);  // never throws
    else reply = {{"ok", false}, {"error", r.error}};
    ptir::dump_json_safe(reply);
  }
  remove_outputs();
  return 0;
}
