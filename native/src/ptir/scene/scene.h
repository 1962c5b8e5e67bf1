// A whole scene: Gaussian field, meshes with materials, lights, environment,
// cameras and integrator settings. Built in code, from a scene JSON file
// (scene_json.h) or from Blender by the add-on.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ptir/lights/emitters.h"
#include "ptir/lights/env_constant.h"
#include "ptir/lights/env_sg.h"
#include "ptir/lights/environment.h"
#include "ptir/lights/environment_light.h"
#include "ptir/scene/camera.h"
#include "ptir/scene/gaussians.h"
#include "ptir/scene/mesh.h"
#include "ptir/scene/render_settings.h"

namespace ptir {

struct Scene {
  std::shared_ptr<GaussianField> gaussians = std::make_shared<GaussianField>();
  std::vector<TriangleMesh> meshes;
  std::vector<Emitter> emitters;
  // Per emitter: whether camera rays see its surface (Blender's Ray Visibility >
  // Camera). Missing entries mean visible.
  std::vector<uint8_t> emitter_visible_camera;
  SceneEnvironment environment;  // any EnvironmentLight, or none (black)
  std::vector<Camera> cameras;
  IntegratorSettings integrator;
  std::string source_path;  // the scene file, for messages
  bool brdf_from_file = false;  // the file named its model ("brdf"); else integrator.brdf is the default

  bool emitter_visible_to_camera(size_t i) const { return i >= emitter_visible_camera.size() || emitter_visible_camera[i]; }

  // Camera by name (throws ptir::Error listing the names when missing); "" = the first.
  const Camera& camera(const std::string& name) const;
};

}  // namespace ptir
