// Scene files: a full example round trip, Gaussian transforms, and every kind of error.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "ptir/core/error.h"
#include "ptir/io/image.h"
#include "ptir/scene/gaussian_ply.h"
#include "ptir/scene/scene_json.h"
#include "ptir/transport/orient_normals.h"
#include "test_scenes.h"

namespace ptir {
namespace {

namespace fs = std::filesystem;

fs::path test_dir() {
  fs::path dir = fs::path(PTIR_TEST_TMP) / "scene_json";
  fs::create_directories(dir);
  return dir;
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p);
  out << text;
}

// Writes the files the example scene refers to (relative to `dir`).
void write_assets(const fs::path& dir) {
  fs::create_directories(dir / "assets");
  GaussianField f;
  test::add_gaussian(f, Vec3(0.1f, 0.2f, 0.3f), Vec3(0.2f, 0.1f, 0.01f), {0.9f, 0.1f, 0.3f, -0.2f}, 0.9f, Vec3(0.5f, 0.4f, 0.3f));
  test::add_gaussian(f, Vec3(-0.4f, 0.0f, 0.5f), Vec3(0.05f, 0.3f, 0.02f), {1.0f, 0.0f, 0.0f, 0.0f}, 0.7f);
  f.normals_from_file = true;
  save_gaussians((dir / "assets" / "splats.ply").string(), f);
  write_text(dir / "assets" / "tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  Image env(8, 4, {"R", "G", "B"});
  for (float& v : env.pixels) v = 0.25f;
  env.at(3, 1, 0) = 5.0f;
  write_image((dir / "assets" / "env.exr").string(), env);
  write_text(dir / "assets" / "transforms_test.json",
             R"({"camera_angle_x": 0.7, "w": 20, "h": 10, "frames": [
                  {"file_path": "./test_000/rgba", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
                  {"file_path": "./test_001/rgba", "transform_matrix": [[1,0,0,1],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]})");
}

const char* kExample = R"({
  "version": 1,
  "comment": "every feature once",
  "gaussians": [
    {"file": "assets/splats.ply"},
    {"file": "assets/splats.ply",
     "transform": [[0, -2, 0, 1], [2, 0, 0, 2], [0, 0, 2, 3], [0, 0, 0, 1]]}
  ],
  "meshes": [
    {"name": "tri", "file": "assets/tri.obj", "transform": [1,0,0,5, 0,1,0,0, 0,0,1,0, 0,0,0,1],
     "material": {"base_color": [0.9, 0.1, 0.2], "roughness": 0.3, "metallic": 1.0}},
    {"vertices": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "triangles": [[0,1,2],[0,2,3]],
     "material": {"name": "lamp", "emission": [2, 3, 4]}}
  ],
  "lights": [
    {"type": "point", "name": "bulb", "position": [0, 0, 3], "power": 100, "color": [1, 0.5, 0.25], "radius": 0.1},
    {"type": "sun", "direction": [0, 0, 2], "strength": 3, "angle": 0.1},
    {"type": "sun", "transform": [[1,0,0,0],[0,0,-1,0],[0,1,0,0],[0,0,0,1]], "strength": 2},
    {"type": "area", "shape": "rectangle", "size": 2, "size_y": 0.5, "power": 80,
     "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,1.5],[0,0,0,1]]},
    {"type": "area", "shape": "disk", "size": 1, "size_y": 7, "power": 50, "color": [0.5, 0.5, 0.5],
     "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,2],[0,0,0,1]]}
  ],
  "environment": {"type": "latlong", "file": "assets/env.exr", "strength": 2.5, "rotation_z": 0.4},
  "cameras": [
    {"name": "front", "transform": [[1,0,0,0],[0,1,0,-1],[0,0,1,6],[0,0,0,1]], "fov_x": 0.8, "width": 64, "height": 48},
    {"transforms": "assets/transforms_test.json"}
  ],
  "integrator": {"spp": 7, "bounces": 4, "seed": 123456789012, "interaction": "discrete", "tau_g": 0.4,
                 "geometric_criterion": false, "self_intersection": "fixed", "self_range_scale": 2.5,
                 "fixed_offset": 0.01, "fixed_range": 0.05, "min_throughput": 0.001,
                 "light_selection": "all", "russian_roulette": false, "min_light_bounces": 3}
})";

TEST(SceneJson, FullExampleRoundTrip) {
  fs::path dir = test_dir() / "example";
  write_assets(dir);
  write_text(dir / "scene.json", kExample);
  Scene s = load_scene_json((dir / "scene.json").string());
  EXPECT_EQ(s.source_path, (dir / "scene.json").string());

  // Gaussians: both files concatenated; the second transformed (rotation 90 deg about z, scale 2, translation).
  GaussianField ref = load_gaussians((dir / "assets" / "splats.ply").string());
  const GaussianField& g = *s.gaussians;
  ASSERT_EQ(g.size(), 4u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_NEAR(g.position[i].x, ref.position[i].x, 1e-6f);
    size_t j = i + 2;
    Vec3 p = ref.position[i];
    EXPECT_NEAR(g.position[j].x, -2 * p.y + 1, 1e-5f);
    EXPECT_NEAR(g.position[j].y, 2 * p.x + 2, 1e-5f);
    EXPECT_NEAR(g.position[j].z, 2 * p.z + 3, 1e-5f);
    EXPECT_NEAR(g.scale[j].x, 2 * ref.scale[i].x, 1e-6f);
    EXPECT_NEAR(g.scale[j].z, 2 * ref.scale[i].z, 1e-6f);
    // Rotated axes: R' = Rz(90) R.
    Mat3 r = ref.rotation_matrix(i), r2 = g.rotation_matrix(j);
    for (int c = 0; c < 3; ++c) {
      Vec3 a = r.col(c), b = r2.col(c);
      EXPECT_NEAR(b.x, -a.y, 1e-5f);
      EXPECT_NEAR(b.y, a.x, 1e-5f);
      EXPECT_NEAR(b.z, a.z, 1e-5f);
    }
    EXPECT_NEAR(g.normal[j].x, -ref.normal[i].y, 1e-5f);
    EXPECT_NEAR(g.normal[j].y, ref.normal[i].x, 1e-5f);
    EXPECT_NEAR(g.albedo[j].x, ref.albedo[i].x, 1e-6f);
    EXPECT_NEAR(g.opacity[j], ref.opacity[i], 1e-6f);
  }
  EXPECT_TRUE(g.normals_from_file);

  // Meshes.
  ASSERT_EQ(s.meshes.size(), 2u);
  EXPECT_EQ(s.meshes[0].name, "tri");
  EXPECT_NEAR(s.meshes[0].vertices[1].x, 6.0f, 1e-6f);
  EXPECT_NEAR(s.meshes[0].material.base_colour.y, 0.1f, 1e-6f);
  EXPECT_NEAR(s.meshes[0].material.roughness, 0.3f, 1e-6f);
  EXPECT_NEAR(s.meshes[0].material.metallic, 1.0f, 1e-6f);
  EXPECT_EQ(s.meshes[1].name, "mesh_1");
  EXPECT_EQ(s.meshes[1].material.name, "lamp");
  EXPECT_EQ(s.meshes[1].triangles.size(), 2u);
  EXPECT_NEAR(s.meshes[1].material.emission.z, 4.0f, 1e-6f);
  EXPECT_NEAR(s.meshes[1].material.roughness, MeshMaterial{}.roughness, 1e-6f);

  // Lights, through the from_blender conversions.
  ASSERT_EQ(s.emitters.size(), 5u);
  const auto& pl = std::get<PointLight>(s.emitters[0]);
  PointLight pl_ref = PointLight::from_blender(Vec3(0, 0, 3), 100.0f, Vec3(1, 0.5f, 0.25f), 0.1f);
  EXPECT_NEAR(pl.intensity.y, pl_ref.intensity.y, 1e-6f);
  EXPECT_NEAR(pl.radius, 0.1f, 1e-7f);
  const auto& sun = std::get<SunLight>(s.emitters[1]);
  EXPECT_NEAR(sun.to_sun.z, 1.0f, 1e-6f);
  EXPECT_NEAR(sun.irradiance.x, 3.0f, 1e-6f);
  EXPECT_NEAR(sun.angle, 0.1f, 1e-7f);
  const auto& sun2 = std::get<SunLight>(s.emitters[2]);  // to_sun = the matrix's z column (0, -1, 0)
  EXPECT_NEAR(sun2.to_sun.y, -1.0f, 1e-6f);
  EXPECT_NEAR(sun2.irradiance.z, 2.0f, 1e-6f);
  const auto& rect = std::get<AreaLight>(s.emitters[3]);
  EXPECT_EQ(rect.shape, AreaShape::Rectangle);
  EXPECT_NEAR(rect.radiance.x, 80.0f / (4.0f * 2.0f * 0.5f), 1e-4f);
  EXPECT_NEAR(rect.normal.z, -1.0f, 1e-6f);
  EXPECT_NEAR(rect.center.z, 1.5f, 1e-6f);
  const auto& disk = std::get<AreaLight>(s.emitters[4]);
  EXPECT_EQ(disk.shape, AreaShape::Ellipse);
  EXPECT_NEAR(disk.size_v, 1.0f, 1e-6f);  // Size Y ignored for disks, as in Blender
  EXPECT_NEAR(disk.radiance.x, 0.5f * 50.0f / (4.0f * 0.25f * kPi), 1e-3f);

  // Environment.
  ASSERT_TRUE(s.environment.as<Environment>());
  EXPECT_FALSE(s.environment.as<SgEnvironment>());
  EXPECT_NEAR(s.environment.as<Environment>()->strength(), 2.5f, 1e-6f);
  EXPECT_NEAR(s.environment.as<Environment>()->rotation_z(), 0.4f, 1e-6f);
  EXPECT_EQ(s.environment.as<Environment>()->width(), 8);

  // Cameras: one explicit, two from the transforms file.
  ASSERT_EQ(s.cameras.size(), 3u);
  EXPECT_EQ(s.cameras[0].name, "front");
  EXPECT_EQ(s.cameras[0].width, 64);
  EXPECT_EQ(s.cameras[0].height, 48);
  EXPECT_NEAR(s.cameras[0].fov_x, 0.8f, 1e-7f);
  EXPECT_NEAR(s.cameras[0].centre().y, -1.0f, 1e-6f);
  EXPECT_EQ(s.cameras[1].name, "test_000");
  EXPECT_EQ(s.cameras[2].width, 20);
  EXPECT_NEAR(s.camera("test_001").centre().x, 1.0f, 1e-6f);

  // Integrator.
  const IntegratorSettings& it = s.integrator;
  EXPECT_EQ(it.spp, 7);
  EXPECT_EQ(it.max_bounces, 4);
  EXPECT_EQ(it.seed, 123456789012ull);
  EXPECT_EQ(it.interaction.mode, InteractionMode::Discrete);
  EXPECT_NEAR(it.interaction.tau_g, 0.4f, 1e-7f);
  EXPECT_FALSE(it.geometric_criterion);
  EXPECT_EQ(it.self_intersection, SelfIntersection::FixedOffset);
  EXPECT_NEAR(it.self_range_scale, 2.5f, 1e-7f);
  EXPECT_NEAR(it.fixed_offset, 0.01f, 1e-7f);
  EXPECT_NEAR(it.fixed_range, 0.05f, 1e-7f);
  EXPECT_NEAR(it.min_throughput, 0.001f, 1e-9f);
  EXPECT_EQ(it.light_selection, LightSelection::All);
  EXPECT_FALSE(it.russian_roulette);
  EXPECT_EQ(it.min_light_bounces, 3);
}

TEST(SceneJson, DefaultsAndOtherEnvironments) {
  Scene s = scene_from_json_string(R"({"environment": {"type": "color", "color": [0.5, 1, 2], "strength": 2}})", "");
  ASSERT_TRUE(s.environment.as<ConstantEnvironment>());
  Vec3 L = s.environment->eval(normalize(Vec3(0.3f, -0.2f, 0.5f)));
  EXPECT_NEAR(L.x, 1.0f, 1e-6f);
  EXPECT_NEAR(L.z, 4.0f, 1e-6f);
  IntegratorSettings def;
  EXPECT_EQ(s.integrator.spp, def.spp);
  EXPECT_EQ(s.integrator.max_bounces, def.max_bounces);
  EXPECT_TRUE(std::isinf(s.integrator.self_range_scale) == std::isinf(def.self_range_scale));
  // Cycles' estimator by default: one light per vertex, Russian roulette from the second vertex.
  EXPECT_EQ(s.integrator.light_selection, LightSelection::One);
  EXPECT_TRUE(s.integrator.russian_roulette);
  EXPECT_EQ(s.integrator.min_light_bounces, 0);
  EXPECT_EQ(s.gaussians->size(), 0u);
  EXPECT_TRUE(s.cameras.empty());

  Scene sg = scene_from_json_string(R"({"environment": {"type": "sg", "lobes": 12, "raw": [-1, -2, -3]},
                                        "integrator": {"self_range_scale": "inf"}})", "");
  ASSERT_TRUE(sg.environment.as<SgEnvironment>());
  EXPECT_EQ(sg.environment.as<SgEnvironment>()->size(), 12);
  EXPECT_NEAR(sg.environment.as<SgEnvironment>()->raw()[5].y, -2.0f, 1e-7f);
  EXPECT_TRUE(std::isinf(sg.integrator.self_range_scale));

  Scene none = scene_from_json_string(R"({"environment": null, "lights": []})", "");
  EXPECT_FALSE(none.environment.present());
}

TEST(SceneJson, PixelFilter) {
  // Default: Blender's Blackman-Harris, 1.5 px; the scene file's values otherwise.
  Scene def = scene_from_json_string("{}", "");
  EXPECT_EQ(def.integrator.filter.type, PixelFilterType::BlackmanHarris);
  EXPECT_FLOAT_EQ(def.integrator.filter.width, 1.5f);
  Scene box = scene_from_json_string(R"({"integrator": {"pixel_filter": "box", "filter_width": 1.0}})", "");
  EXPECT_EQ(box.integrator.filter.type, PixelFilterType::Box);
  EXPECT_FLOAT_EQ(box.integrator.filter.width, 1.0f);
  Scene g = scene_from_json_string(R"({"integrator": {"pixel_filter": "gaussian", "filter_width": 0}})", "");
  EXPECT_EQ(g.integrator.filter.type, PixelFilterType::Gaussian);
  EXPECT_FLOAT_EQ(g.integrator.filter.width, 0.0f);
  auto message = [](const char* text) {
    try {
      scene_from_json_string(text, "s.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message(R"({"integrator": {"filter_width": -1}})").find("filter_width"), std::string::npos);
  EXPECT_NE(message(R"({"integrator": {"pixel_filter": "mitchell"}})").find("pixel_filter"), std::string::npos);
}

TEST(SceneJson, GaussianTransformMatchesCovarianceAlgebra) {
  GaussianField f = test::random_field(20, 7);
  GaussianField orig = f;
  // Rotation about a skew axis times 1.7, plus translation; then a mirror.
  for (bool mirror : {false, true}) {
    f = orig;
    Vec3 axis = normalize(Vec3(0.3f, -0.5f, 0.8f));
    float ang = 0.9f, c = std::cos(ang), sn = std::sin(ang), t = 1 - c;
    Mat3 R = Mat3::from_rows(Vec3(t * axis.x * axis.x + c, t * axis.x * axis.y - sn * axis.z, t * axis.x * axis.z + sn * axis.y),
                             Vec3(t * axis.x * axis.y + sn * axis.z, t * axis.y * axis.y + c, t * axis.y * axis.z - sn * axis.x),
                             Vec3(t * axis.x * axis.z - sn * axis.y, t * axis.y * axis.z + sn * axis.x, t * axis.z * axis.z + c));
    if (mirror) R = R * Mat3::from_rows(Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(0, 0, 1));
    const float s = 1.7f;
    float m[16] = {s * R.m[0][0], s * R.m[0][1], s * R.m[0][2], 0.5f, s * R.m[1][0], s * R.m[1][1], s * R.m[1][2], -1.0f,
                   s * R.m[2][0], s * R.m[2][1], s * R.m[2][2], 2.0f, 0, 0, 0, 1};
    transform_gaussians(f, m, "test");
    for (size_t i = 0; i < f.size(); ++i) {
      // Sigma' = A Sigma A^T with A = s R.
      auto cov = [](const GaussianField& g, size_t k) {
        Mat3 r = g.rotation_matrix(k);
        Mat3 S = Mat3::from_rows(Vec3(g.scale[k].x, 0, 0), Vec3(0, g.scale[k].y, 0), Vec3(0, 0, g.scale[k].z));
        Mat3 rs = r * S;
        return rs * transpose(rs);
      };
      Mat3 A = R;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) A.m[a][b] *= s;
      Mat3 expect = A * cov(orig, i) * transpose(A);
      Mat3 got = cov(f, i);
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) EXPECT_NEAR(got.m[a][b], expect.m[a][b], 2e-5f) << i << " mirror " << mirror;
      Vec3 p = A * orig.position[i] + Vec3(0.5f, -1.0f, 2.0f);
      EXPECT_NEAR(f.position[i].x, p.x, 1e-5f);
      Vec3 n = R * orig.normal[i];
      EXPECT_NEAR(dot(f.normal[i], n), 1.0f, 1e-5f);
      // A proper rotation quaternion: unit, w >= 0.
      const auto& q = f.rotation[i];
      EXPECT_NEAR(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0f, 1e-5f);
      EXPECT_GE(q[0], 0.0f);
    }
  }
}

TEST(SceneJson, NonUniformScaleIsRefused) {
  GaussianField f = test::random_field(3, 1);
  float m[16] = {1, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  try {
    transform_gaussians(f, m, "splats.ply");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("splats.ply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("non-uniform scale"), std::string::npos) << e.what();
  }
}

TEST(SceneJson, QuaternionOfRotationMatrix) {
  GaussianField f = test::random_field(50, 3);
  for (size_t i = 0; i < f.size(); ++i) {
    auto q = mat3_to_quat(f.rotation_matrix(i));
    Mat3 a = f.rotation_matrix(i), b = quat_to_mat3(q[0], q[1], q[2], q[3]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(a.m[r][c], b.m[r][c], 1e-5f);
  }
}

TEST(SceneJson, ConcatenatesShDegrees) {
  GaussianField a = test::random_field(2, 1), b = test::random_field(3, 2);
  b.sh_degree = 1;
  b.sh.assign(3 * 12, 0.25f);
  append_gaussians(a, std::move(b));
  EXPECT_EQ(a.size(), 5u);
  EXPECT_EQ(a.sh_degree, 1);
  ASSERT_EQ(a.sh.size(), 5u * 12u);
  EXPECT_EQ(a.sh[3], 0.0f);       // padded higher coefficient of a Gaussian of degree 0
  EXPECT_EQ(a.sh[2 * 12 + 5], 0.25f);
}

// Every error kind: the message names the file and the JSON path.
struct ErrorCase {
  const char* json;
  const char* expect;  // substring of the message, after "scene.json: "
};

void PrintTo(const ErrorCase& c, std::ostream* os) { *os << c.json; }

class SceneJsonErrors : public ::testing::TestWithParam<ErrorCase> {};

TEST_P(SceneJsonErrors, NameFileAndPath) {
  // A folder per case: ctest -j runs the cases as separate processes at once.
  fs::path dir = test_dir() / ("errors_" + std::to_string(std::hash<std::string>{}(GetParam().json)));
  write_assets(dir);
  write_text(dir / "scene.json", GetParam().json);
  try {
    load_scene_json((dir / "scene.json").string());
    FAIL() << "no error for " << GetParam().json;
  } catch (const Error& e) {
    std::string msg = e.what();
    std::string prefix = (dir / "scene.json").string() + ": ";
    EXPECT_EQ(msg.rfind(prefix, 0), 0u) << msg;
    EXPECT_NE(msg.find(GetParam().expect), std::string::npos) << "message: " << msg << "\nexpected: " << GetParam().expect;
  }
}

INSTANTIATE_TEST_SUITE_P(
    AllKinds, SceneJsonErrors,
    ::testing::Values(
        ErrorCase{"{\"meshes\": [", "invalid JSON"},
        ErrorCase{"[1, 2]", "the scene must be a JSON object"},
        ErrorCase{R"({"light": []})", "light is not a known key (expected one of: version"},
        ErrorCase{R"({"lights": [{"type": "point", "position": [0,0,0], "power": 1},
                                 {"type": "sun", "direction": [0, 0, 1]},
                                 {"type": "point", "position": [0,0,0], "power": "100"}]})",
                  "lights[2].power must be a number, got a string"},
        ErrorCase{R"({"lights": [{"type": "point", "position": [0,0,0], "powr": 1}]})",
                  "lights[0].powr is not a known key (expected one of: type, name, position, power, color, radius, visible_camera)"},
        ErrorCase{R"({"lights": [{"type": "area", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]})",
                  "lights[0].power is required"},
        ErrorCase{R"({"lights": [{"type": "spot", "power": 1}]})", "lights[0].type must be one of 'point', 'sun', 'area', got 'spot'"},
        ErrorCase{R"({"lights": [{"type": "sun", "direction": [0,0,1], "transform": [1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}]})",
                  "lights[0] needs exactly one of \"direction\""},
        ErrorCase{R"({"lights": [{"type": "point", "position": [0,0], "power": 1}]})", "lights[0].position must be a list of 3 numbers"},
        ErrorCase{R"({"lights": [{"type": "point", "position": [0,0,0], "power": -1}]})", "lights[0].power must be in [0"},
        ErrorCase{R"({"lights": {"type": "point"}})", "lights must be a list, got an object"},
        ErrorCase{R"({"meshes": [{"file": "assets/missing.obj"}]})", "meshes[0].file: "},
        ErrorCase{R"({"meshes": [{"file": "assets/tri.obj", "vertices": [[0,0,0]]}]})", "meshes[0] needs either \"file\""},
        ErrorCase{R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,3]]}]})",
                  "meshes[0].triangles[0][2] is out of range (the mesh has 3 vertices)"},
        ErrorCase{R"({"meshes": [{"file": "assets/tri.obj", "material": {"base_colour": [1,1,1]}}]})",
                  "meshes[0].material.base_colour is not a known key"},
        ErrorCase{R"({"meshes": [{"file": "assets/tri.obj", "material": {"base_color": [1.5,1,1]}}]})",
                  "meshes[0].material.base_color components must be in [0, 1]"},
        ErrorCase{R"({"meshes": [{"file": "assets/tri.obj", "material": {"roughness": 2}}]})",
                  "meshes[0].material.roughness must be in [0, 1], got 2"},
        ErrorCase{R"({"meshes": [{"file": "assets/tri.obj", "transform": [[1,0,0],[0,1,0],[0,0,1]]}]})",
                  "meshes[0].transform must be a 4x4 matrix"},
        ErrorCase{R"({"meshes": [{"file": "assets/tri.obj", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]}]})",
                  "meshes[0].transform must be an affine matrix"},
        ErrorCase{R"({"gaussians": [{"file": "assets/splats.ply", "transform": [[1,0,0,0],[0,3,0,0],[0,0,1,0],[0,0,0,1]]}]})",
                  "gaussians[0].transform: " },
        ErrorCase{R"({"gaussians": [{"file": "assets/splats.ply", "transform": [[1,0,0,0],[0,3,0,0],[0,0,1,0],[0,0,0,1]]}]})",
                  "non-uniform scale"},
        ErrorCase{R"({"gaussians": [{"file": "assets/nope.ply"}]})", "gaussians[0].file: "},
        ErrorCase{R"({"gaussians": ["assets/splats.ply"]})", "gaussians[0] must be an object, got a string"},
        ErrorCase{R"({"environment": {"type": "hdri", "file": "x.exr"}})", "environment.type must be one of 'latlong', 'color', 'sg'"},
        ErrorCase{R"({"environment": {"type": "latlong"}})", "environment.file is required"},
        ErrorCase{R"({"environment": {"type": "latlong", "file": "assets/env.exr", "rotation": 1}})",
                  "environment.rotation is not a known key"},
        ErrorCase{R"({"environment": {"type": "sg", "lobes": 4, "raw": [[0,0,0]]}})", "environment.raw must be one [r, g, b] or one per lobe (4), got 1"},
        ErrorCase{R"({"cameras": [{"name": "a", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "fov_x": 4, "width": 8, "height": 8}]})",
                  "cameras[0].fov_x must be in (0, 3.14159"},
        ErrorCase{R"({"cameras": [{"name": "a", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "fov_x": 1, "width": 8.5, "height": 8}]})",
                  "cameras[0].width must be an integer"},
        ErrorCase{R"({"cameras": [{"name": "a", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "fov_x": 1, "height": 8}]})",
                  "cameras[0].width is required"},
        ErrorCase{R"({"cameras": [{"name": "a", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "fov_x": 1, "width": 8, "height": 8},
                                  {"name": "a", "transform": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "fov_x": 1, "width": 8, "height": 8}]})",
                  "cameras has two cameras named 'a'"},
        ErrorCase{R"({"cameras": [{"transforms": "assets/none.json"}]})", "cameras[0].transforms: "},
        ErrorCase{R"({"integrator": {"spp": 0}})", "integrator.spp must be in [1, "},
        ErrorCase{R"({"integrator": {"light_selection": "some"}})", "integrator.light_selection must be one of 'one', 'all'"},
        ErrorCase{R"({"integrator": {"bounce": 2}})", "integrator.bounce is not a known key"},
        ErrorCase{R"({"integrator": {"interaction": "mean"}})", "integrator.interaction must be one of 'aggregate', 'discrete', got 'mean'"},
        ErrorCase{R"({"integrator": {"geometric_criterion": 1}})", "integrator.geometric_criterion must be true or false"},
        ErrorCase{R"({"integrator": {"self_intersection": "offset"}})", "integrator.self_intersection must be one of 'backface', 'fixed'"},
        ErrorCase{R"({"integrator": {"seed": -1}})", "integrator.seed must be a non-negative integer"},
        ErrorCase{R"({"version": 2})", "version must be in [1, 1], got 2"}));

TEST(SceneJson, MissingFileAndRelativePaths) {
  try {
    load_scene_json((test_dir() / "does_not_exist.json").string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("does_not_exist.json: cannot open"), std::string::npos) << e.what();
  }
  // Relative paths resolve against base_dir, not the working directory.
  fs::path dir = test_dir() / "relative";
  write_assets(dir);
  Scene s = scene_from_json_string(R"({"meshes": [{"file": "assets/tri.obj"}]})", dir.string(), "inline");
  EXPECT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.source_path, "inline");
  try {
    scene_from_json_string(R"({"meshes": [{"file": "assets/tri.obj"}]})", (dir / "elsewhere").string(), "inline");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("inline: meshes[0].file: ", 0), 0u) << e.what();
  }
}

TEST(SceneJson, ShortestAxisNormalsFaceTheCameras) {
  // A flat splat facing +z seen from +z: its normal must end up +z; seen from -z, -z.
  fs::path dir = test_dir() / "orient";
  fs::create_directories(dir);
  GaussianField f;
  test::add_gaussian(f, Vec3(0, 0, 0), Vec3(0.5f, 0.5f, 0.001f), {1, 0, 0, 0}, 0.95f);
  f.normal[0] = Vec3(0, 0, -1);  // wrong sign on purpose; not written (normals_from_file = false)
  f.normals_from_file = false;
  save_gaussians((dir / "flat.ply").string(), f);
  // save writes nx,ny,nz; zero them so the loader treats them as absent.
  GaussianField g = load_gaussians((dir / "flat.ply").string());
  g.normal[0] = Vec3(0.0f);
  g.normals_from_file = false;
  save_gaussians((dir / "flat0.ply").string(), g);
  for (float side : {1.0f, -1.0f}) {
    std::string cam = side > 0 ? "[[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]" : "[[-1,0,0,0],[0,1,0,0],[0,0,-1,-3],[0,0,0,1]]";
    std::string text = R"({"gaussians": [{"file": "flat0.ply"}], "cameras": [{"transform": )" + cam +
                       R"(, "fov_x": 0.5, "width": 16, "height": 16}]})";
    Scene s = scene_from_json_string(text, dir.string());
    ASSERT_EQ(s.gaussians->size(), 1u);
    orient_scene_normals(s);  // the renderers' step after loading
    EXPECT_NEAR(s.gaussians->normal[0].z, side, 1e-5f);
  }
}

// Inline shading normals, one per vertex, carried by the mesh's transform as normals are: by the
// inverse transpose (here diag(2, 1, -1), a mirror: diag(1/2, 1, -1)), and refused where misplaced.
TEST(SceneJson, MeshNormalsFollowTheInverseTranspose) {
  const fs::path dir = test_dir();
  Scene s = scene_from_json_string(
      R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]],
                      "normals": [[1,0,1],[0,0,3],[0,0,1]],
                      "transform": [[2,0,0,0],[0,1,0,0],[0,0,-1,0],[0,0,0,1]]}]})",
      dir.string(), "inline");
  ASSERT_EQ(s.meshes[0].normals.size(), 3u);
  const Vec3 n0 = s.meshes[0].normals[0], expected = normalize(Vec3(0.5f, 0.0f, -1.0f));
  EXPECT_NEAR(n0.x, expected.x, 1e-6);
  EXPECT_NEAR(n0.z, expected.z, 1e-6);
  EXPECT_NEAR(s.meshes[0].normals[1].z, -1.0f, 1e-6);
  // The (mirrored, rewound) face and the interpolated normal still agree on the side.
  EXPECT_GT(dot(s.meshes[0].face_normal(0), s.meshes[0].shading_normal(0, 0.3f, 0.3f)), 0.9f);
  for (const char* bad : {R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]],
                                           "normals": [[0,0,1]]}]})",
                          R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]],
                                           "normals": [[0,0,1],[0,0,0],[0,0,1]]}]})"}) {
    EXPECT_THROW(scene_from_json_string(bad, dir.string(), "inline"), Error) << bad;
  }
}

}  // namespace
}  // namespace ptir
