// Which surface model a run uses (material/shading_model.h, scene/dataset.h): the
// names ("principled" = v1), the scene file's "brdf" and its default (v2), the v2
// mesh-material fields, a dataset's recorded "ptir_brdf", and the precedence.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "ptir/io/image.h"
#include "ptir/material/bsdf.h"
#include "ptir/scene/dataset.h"
#include "ptir/scene/scene_json.h"

using namespace ptir;
namespace fs = std::filesystem;

TEST(BsdfModelChoice, NamesRoundTripAndOldNameIsV1) {
  for (BsdfModel m : {BsdfModel::PrincipledV1, BsdfModel::PrincipledV2, BsdfModel::DisneySimplified})
    EXPECT_EQ(parse_bsdf_model(to_string(m)), m);
  EXPECT_EQ(parse_bsdf_model("principled"), BsdfModel::PrincipledV1);
  EXPECT_FALSE(parse_bsdf_model("principled-v3"));
  EXPECT_EQ(resolve_bsdf(BsdfModel::PrincipledV2, SurfaceShader::PrincipledMultiGGX), BsdfKind::PrincipledV2MultiGGX);
  EXPECT_EQ(resolve_bsdf(BsdfModel::PrincipledV2, SurfaceShader::PrincipledGGX), BsdfKind::PrincipledV2GGX);
  EXPECT_EQ(resolve_bsdf(BsdfModel::PrincipledV1, SurfaceShader::PrincipledGGX), BsdfKind::PrincipledGGX);
}

TEST(BsdfModelChoice, SceneFileBrdfAndDefault) {
  Scene none = scene_from_json_string("{}", ".", "a.json");
  EXPECT_FALSE(none.brdf_from_file);
  EXPECT_EQ(none.integrator.brdf, BsdfModel::PrincipledV2);
  Scene old = scene_from_json_string(R"({"brdf": "principled"})", ".", "b.json");
  EXPECT_TRUE(old.brdf_from_file);
  EXPECT_EQ(old.integrator.brdf, BsdfModel::PrincipledV1);
  EXPECT_EQ(scene_from_json_string(R"({"brdf": "principled-v2"})", ".").integrator.brdf, BsdfModel::PrincipledV2);
  test::expect_error([] { scene_from_json_string(R"({"brdf": "principled-v9"})", ".", "c.json"); }, "c.json",
                     {"brdf", "principled-v2"});
}

TEST(BsdfModelChoice, MeshMaterialV2Fields) {
  Scene s = scene_from_json_string(R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]],
      "material": {"ior": 1.33, "specular_ior_level": 0.2, "specular_tint_color": [1, 0.5, 0.25],
                   "diffuse_roughness": 0.7}}]})", ".");
  const MeshMaterial& m = s.meshes[0].material;
  EXPECT_FLOAT_EQ(m.ior, 1.33f);
  EXPECT_FLOAT_EQ(m.specular_ior_level, 0.2f);
  EXPECT_FLOAT_EQ(m.specular_tint_color.z, 0.25f);
  EXPECT_FLOAT_EQ(m.diffuse_roughness, 0.7f);
  const MeshMaterial d = scene_from_json_string(R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]],
      "triangles": [[0,1,2]]}]})", ".").meshes[0].material;
  EXPECT_FLOAT_EQ(d.ior, 1.5f);
  EXPECT_FLOAT_EQ(d.specular_ior_level, 0.5f);
  EXPECT_FLOAT_EQ(d.specular_tint_color.y, 1.0f);
  EXPECT_FLOAT_EQ(d.diffuse_roughness, 0.0f);
  test::expect_error([] {
    scene_from_json_string(R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]],
        "material": {"specular_ior_level": 1.5}}]})", ".", "d.json");
  }, "d.json", {"specular_ior_level"});
  test::expect_error([] {
    scene_from_json_string(R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[0,1,0]], "triangles": [[0,1,2]],
        "material": {"specular_tint_color": [1, -0.5, 0]}}]})", ".", "e.json");
  }, "e.json", {"specular_tint_color"});
}

TEST(BsdfModelChoice, DatasetRecordAndPrecedence) {
  const fs::path dir = fs::path(PTIR_TEST_TMP) / "bsdf_model_choice";
  fs::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  EXPECT_EQ(read_recorded_bsdf_model(write("v1.json", R"({"ptir_brdf": "principled-v1", "frames": []})")),
            BsdfModel::PrincipledV1);
  EXPECT_FALSE(read_recorded_bsdf_model(write("none.json", R"({"frames": []})")));
  const std::string bad = write("bad.json", R"({"ptir_brdf": 3, "frames": []})");
  test::expect_error([&] { read_recorded_bsdf_model(bad); }, bad, {"ptir_brdf"});
  // Sets that name only their maker: the Blender version decides (dataset.json beside the camera file too).
  EXPECT_EQ(read_recorded_bsdf_model(write("g34.json", R"J({"generator": "make_dataset.py (Blender 3.4.1, Cycles)"})J")),
            BsdfModel::PrincipledV1);
  EXPECT_EQ(read_recorded_bsdf_model(write("g45.json", R"J({"generator": "make_dataset.py (Blender 4.5.15, Cycles)"})J")),
            BsdfModel::PrincipledV2);
  EXPECT_FALSE(read_recorded_bsdf_model(write("g.json", R"({"generator": "something else"})")));
  const fs::path sub = dir / "with_meta";
  fs::create_directories(sub);
  std::ofstream(sub / "transforms_train.json") << R"({"frames": []})";
  std::ofstream(sub / "dataset.json") << R"J({"generator": "scripts/make_dataset.py (Blender 3.4.1, Cycles)"})J";
  EXPECT_EQ(read_recorded_bsdf_model((sub / "transforms_train.json").string()), BsdfModel::PrincipledV1);
  // Scene file first, then the dataset's record, then v2.
  EXPECT_EQ(resolve_bsdf_model(true, BsdfModel::DisneySimplified, BsdfModel::PrincipledV1), BsdfModel::DisneySimplified);
  EXPECT_EQ(resolve_bsdf_model(false, BsdfModel::DisneySimplified, BsdfModel::PrincipledV1), BsdfModel::PrincipledV1);
  EXPECT_EQ(resolve_bsdf_model(false, BsdfModel::PrincipledV1, std::nullopt), BsdfModel::PrincipledV2);
}

// A capture's DIR/dataset.json names the model too (issue 38: a set converted to COLMAP by
// scripts/nerf_to_colmap.py keeps its record, so both layouts render with the same model).
TEST(BsdfModelChoice, CaptureRecordInEveryLayout) {
  const fs::path dir = fs::path(PTIR_TEST_TMP) / "bsdf_model_choice_colmap";
  fs::remove_all(dir);
  fs::create_directories(dir / "sparse" / "0");
  fs::create_directories(dir / "images");
  std::ofstream(dir / "sparse" / "0" / "cameras.txt") << "1 PINHOLE 8 8 10 10 4 4\n";
  std::ofstream(dir / "sparse" / "0" / "images.txt") << "1 1 0 0 0 0 0 4 1 a.png\n\n2 1 0 0 0 0 0 5 1 b.png\n\n";
  write_image((dir / "images" / "a.png").string(), Image(8, 8, {"R", "G", "B"}));
  write_image((dir / "images" / "b.png").string(), Image(8, 8, {"R", "G", "B"}));
  DatasetOptions all;
  all.split = "all";
  EXPECT_FALSE(load_dataset(dir.string(), all)->brdf);  // a photographed capture records nothing: the default
  std::ofstream(dir / "dataset.json") << R"J({"generator": "scripts/make_dataset.py (Blender 3.4.1, Cycles)"})J";
  EXPECT_EQ(load_dataset(dir.string(), all)->brdf, BsdfModel::PrincipledV1);
  std::ofstream(dir / "dataset.json") << R"J({"ptir_brdf": "principled-v2"})J";
  EXPECT_EQ(load_dataset(dir.string(), all)->brdf, BsdfModel::PrincipledV2);
}
