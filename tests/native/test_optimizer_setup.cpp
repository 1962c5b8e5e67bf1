// The optimiser's set-up with the scene file's own light (optimizer_setup.h, docs/known_lamps.md):
// --env none (no environment: the lamps alone) and its refusals, and the learnt environment's dark
// start with no albedo warm-up where the file brings lamps.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "expect_error.h"
#include "ptir/optim/optimizer_setup.h"
#include "ptir/optim/parameters.h"

namespace fs = std::filesystem;
using namespace ptir;

namespace {

const char* kTriangle = R"("meshes": [{"name": "wall", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 2]]}])";

// A scene file in the test's temp folder: a wall, and a point lamp when `lamp`.
std::string scene_file(const std::string& name, bool lamp) {
  const fs::path p = fs::temp_directory_path() / ("ptir_setup_" + name + ".json");
  std::ofstream(p) << "{" << kTriangle
                   << (lamp ? R"(, "lights": [{"type": "point", "position": [0, 0, 2], "power": 10}])" : "") << "}";
  return p.string();
}

OptimizerSettings settings_for(const std::string& env) {
  OptimizeOptions o;
  o.env = env;
  return optimizer_settings(o, cli_option_name);
}

}  // namespace

TEST(OptimizerSetup, EnvNoneInstallsNoEnvironmentAndLearnsNone) {
  EXPECT_EQ(parse_env_mode("none"), EnvMode::None);
  EXPECT_STREQ(env_mode_name(EnvMode::None), "none");
  OptimizerSettings s = settings_for("none");
  Scene scene = prepare_optimizer_scene(scene_file("lit", true), std::make_shared<GaussianField>(), s, cli_option_name);
  install_environment(scene, s.params);
  EXPECT_FALSE(scene.environment.present());
  const Parameters p = make_parameters(scene, s.params);
  EXPECT_EQ(p.find(ParamKind::Environment), nullptr);
  EXPECT_EQ(p.find(ParamKind::EnvironmentCoarse), nullptr);
  EXPECT_EQ(s.albedo_warmup, OptimizerSettings{}.albedo_warmup);  // nothing learnt besides: the usual warm-up
}

TEST(OptimizerSetup, EnvNoneRefusesARunWithNoLightToGive) {
  OptimizerSettings s = settings_for("none");
  const std::string unlit = scene_file("unlit", false);
  test::expect_error([&] { prepare_optimizer_scene(unlit, std::make_shared<GaussianField>(), s, cli_option_name); }, unlit,
                     {"--env none", "it has none"});
  test::expect_error([&] { prepare_optimizer_scene("", std::make_shared<GaussianField>(), s, cli_option_name); }, "--env none",
                     {"there is no --scene"});
  OptimizeOptions o;
  o.env = "none";
  o.env_init = "map.exr";
  test::expect_error([&] { optimizer_settings(o, cli_option_name); }, "--env-init", {"needs an environment model"});
}

TEST(OptimizerSetup, TheScenesLampsStartALearntEnvironmentDark) {
  OptimizerSettings lit = settings_for("latlong");
  prepare_optimizer_scene(scene_file("lamps", true), std::make_shared<GaussianField>(), lit, cli_option_name);
  EXPECT_EQ(lit.params.env_init, kSceneLitEnvStart);
  EXPECT_EQ(lit.albedo_warmup, 0.0f);
  // Without the scene's own light, or with the warm-up given: the defaults and the given value.
  OptimizerSettings walls = settings_for("latlong");
  prepare_optimizer_scene(scene_file("walls", false), std::make_shared<GaussianField>(), walls, cli_option_name);
  EXPECT_EQ(walls.params.env_init, ParameterSettings{}.env_init);
  EXPECT_EQ(walls.albedo_warmup, OptimizerSettings{}.albedo_warmup);
  OptimizeOptions o;
  o.albedo_warmup = 0.25f;
  OptimizerSettings given = optimizer_settings(o, cli_option_name);
  prepare_optimizer_scene(scene_file("given", true), std::make_shared<GaussianField>(), given, cli_option_name);
  EXPECT_EQ(given.albedo_warmup, 0.25f);
  EXPECT_EQ(given.params.env_init, kSceneLitEnvStart);
}
