#include "ptir/scene/scene.h"

#include "ptir/core/error.h"

namespace ptir {

const Camera& Scene::camera(const std::string& name) const {
  if (cameras.empty()) throw Error(source_path.empty() ? "scene" : source_path, "the scene has no camera");
  if (name.empty()) return cameras.front();
  std::string names;
  for (const Camera& c : cameras) {
    if (c.name == name) return c;
    names += (names.empty() ? "" : ", ") + c.name;
  }
  throw Error(source_path.empty() ? "scene" : source_path, "no camera named '" + name + "' (cameras: " + names + ")");
}

}  // namespace ptir
