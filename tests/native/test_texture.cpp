// Image textures on meshes: lookups as Cycles' kernel does them (bilinear between
// texel centres, Closest, Repeat, sRGB decoded after filtering 8-bit files), the
// PLY's UVs and tangents, the tangent-space normal map, and errors naming the file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "expect_error.h"
#include "ptir/io/image.h"
#include "ptir/material/bsdf.h"
#include "ptir/scene/mesh.h"
#include "ptir/scene/mesh_surface.h"
#include "ptir/scene/mesh_tangents.h"
#include "ptir/scene/scene_json.h"
#include "ptir/scene/texture_load.h"

using namespace ptir;

namespace {

std::filesystem::path tex_dir() {
  const std::filesystem::path dir = std::filesystem::path(PTIR_TEST_TMP) / "texture";
  std::filesystem::create_directories(dir);
  return dir;
}

// A 2 x 2 RGB image, top row first as files store it: top (a, b), bottom (c, d).
std::string write_2x2(const std::string& name, Vec3 a, Vec3 b, Vec3 c, Vec3 d, Encoding enc) {
  Image img(2, 2, {"R", "G", "B"});
  const Vec3 px[4] = {a, b, c, d};
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 3; ++k) img.at(i % 2, i / 2, k) = px[i][k];
  const std::string path = (tex_dir() / name).string();
  write_image(path, img, enc);
  return path;
}

void expect_vec(Vec3 a, Vec3 b, float tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

}  // namespace

TEST(Texture, BilinearClosestAndRepeatAsCycles) {
  // EXR: values as stored (Non-Color). v = 0 is the image's bottom row (c, d).
  const Vec3 a(1, 0, 0), b(0, 1, 0), c(0, 0, 1), d(1, 1, 1);
  const std::string path = write_2x2("quad.exr", a, b, c, d, Encoding::Data);
  auto lin = load_texture(path, TextureColourSpace::NonColor, TextureInterpolation::Linear);
  // Texel centres: (0.25, 0.25) is the bottom-left texel exactly.
  expect_vec(lin->rgb({0.25f, 0.25f}), c, 1e-6f);
  expect_vec(lin->rgb({0.75f, 0.75f}), b, 1e-6f);
  // Halfway between the bottom texels; the image's centre is the mean of all four.
  expect_vec(lin->rgb({0.5f, 0.25f}), 0.5f * (c + d), 1e-6f);
  expect_vec(lin->rgb({0.5f, 0.5f}), 0.25f * (a + b + c + d), 1e-6f);
  // Repeat: at u = 0 the left texel blends with the right one across the edge; whole periods wrap.
  expect_vec(lin->rgb({0.0f, 0.25f}), 0.5f * (c + d), 1e-6f);
  expect_vec(lin->rgb({3.25f, -1.75f}), c, 1e-5f);
  auto nearest = load_texture(path, TextureColourSpace::NonColor, TextureInterpolation::Closest);
  expect_vec(nearest->rgb({0.49f, 0.51f}), a, 0.0f);
  expect_vec(nearest->rgb({0.51f, 0.49f}), d, 0.0f);
  expect_vec(nearest->rgb({-0.01f, 0.01f}), d, 0.0f);  // wraps to the right column
}

TEST(Texture, SrgbBytesDecodeAfterFiltering) {
  // An 8-bit file holding sRGB values 0 and 1 side by side: Cycles filters the encoded
  // values and decodes the result, so halfway gives srgb_to_linear(0.5), not 0.5.
  const std::string path = write_2x2("bw.png", Vec3(0), Vec3(1), Vec3(0), Vec3(1), Encoding::Data);
  auto srgb = load_texture(path, TextureColourSpace::Srgb, TextureInterpolation::Linear);
  EXPECT_NEAR(srgb->rgb({0.5f, 0.25f}).x, srgb_to_linear(0.5f), 1e-5f);
  auto data = load_texture(path, TextureColourSpace::NonColor, TextureInterpolation::Linear);
  EXPECT_NEAR(data->rgb({0.5f, 0.25f}).x, 0.5f, 1e-5f);
}

TEST(Texture, NormalMapInTangentSpace) {
  // A unit quad in the xy plane, UVs = (x, y): tangent +x, bitangent +y, normal +z.
  TriangleMesh mesh;
  mesh.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  mesh.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  compute_tangents(mesh);
  ASSERT_EQ(mesh.tangents.size(), 4u);
  expect_vec(mesh.tangents[2], Vec3(1, 0, 0), 1e-6f);
  EXPECT_EQ(mesh.tangent_signs[2], 1.0f);
  // A normal map tilted toward +u: colour (0.5 + s/2, 0.5, 0.5 + c/2) for a 30 degree tilt.
  const float s = 0.5f, c = std::sqrt(3.0f) / 2.0f;
  const Vec3 col(0.5f + 0.5f * s, 0.5f, 0.5f + 0.5f * c);
  mesh.material.normal_map = load_texture(write_2x2("tilt.exr", col, col, col, col, Encoding::Data),
                                          TextureColourSpace::NonColor, TextureInterpolation::Linear);
  const Vec3 down(0, 0, -1);  // seen from above
  expect_vec(mesh_surface(mesh, 0, 0.3f, 0.2f, down, Vec3(0, 0, 1)).n, Vec3(s, 0, c), 1e-5f);
  // From below the mapped normal is mirrored (Cycles' back face), on the viewer's side.
  expect_vec(mesh_surface(mesh, 0, 0.3f, 0.2f, -down, Vec3(0, 0, -1)).n, Vec3(-s, 0, -c), 1e-5f);
  // Strength 0: the surface's own normal.
  mesh.material.normal_map_strength = 0.0f;
  expect_vec(mesh_surface(mesh, 0, 0.3f, 0.2f, down, Vec3(0, 0, 1)).n, Vec3(0, 0, 1), 1e-6f);
  // A mirrored UV island (u running along -x) flips the tangent; the bitangent sign keeps +y.
  TriangleMesh mirrored = mesh;
  mirrored.tangents.clear();
  mirrored.uvs = {{1, 0}, {0, 0}, {0, 1}, {1, 1}};
  compute_tangents(mirrored);
  expect_vec(mirrored.tangents[0], Vec3(-1, 0, 0), 1e-6f);
  EXPECT_EQ(mirrored.tangent_signs[0], -1.0f);
}

TEST(Texture, TexturedMaterialInSceneFile) {
  const std::string tex = write_2x2("albedo.png", Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1), Vec3(1, 1, 1), Encoding::Data);
  const std::string mesh_json =
      R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[1,1,0]], "triangles": [[0,1,2]],
          "uvs": [[0.25,0.25],[0.75,0.25],[0.75,0.75]],
          "material": {"base_color": {"texture": "albedo.png", "interpolation": "closest"},
                       "roughness": {"texture": "albedo.png"}, "metallic": 0.25}}]})";
  const Scene scene = scene_from_json_string(mesh_json, tex_dir().string(), "tex.json");
  const TriangleMesh& m = scene.meshes.at(0);
  ASSERT_TRUE(m.material.base_colour_map && m.material.roughness_map);
  EXPECT_EQ(m.material.base_colour_map->interpolation, TextureInterpolation::Closest);
  EXPECT_TRUE(m.material.base_colour_map->decode_srgb_after_filter);  // base colour: sRGB by default
  EXPECT_FALSE(m.material.roughness_map->decode_srgb_after_filter);   // float inputs: Non-Color by default
  // Corner 0 (uv (0.25, 0.25)) is the bottom-left texel: blue; its luminance is the roughness.
  const MeshSurface s = mesh_surface(m, 0, 0.0f, 0.0f, Vec3(0, 0, -1), Vec3(0, 0, 1));
  expect_vec(s.material.albedo, Vec3(0, 0, 1), 1e-6f);
  EXPECT_NEAR(s.material.roughness, 0.0722f, 1e-5f);
  EXPECT_NEAR(s.material.metallic, 0.25f, 1e-6f);
  // Bad texture files: the error names the scene file, the key and the image.
  const std::string missing = (tex_dir() / "missing.png").string();
  test::expect_error([&] {
    scene_from_json_string(R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[1,1,0]], "triangles": [[0,1,2]],
        "material": {"base_color": {"texture": "missing.png"}}}]})", tex_dir().string(), "tex.json");
  }, missing, {"tex.json", "meshes[0].material.base_color.texture"});
  const std::string junk = (tex_dir() / "junk.png").string();
  std::ofstream(junk) << "not an image";
  test::expect_error([&] {
    scene_from_json_string(R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[1,1,0]], "triangles": [[0,1,2]],
        "material": {"normal_map": {"texture": "junk.png", "strength": 0.5}}}]})", tex_dir().string(), "tex.json");
  }, junk, {"normal_map.texture"});
  test::expect_error([&] {
    scene_from_json_string(R"({"meshes": [{"vertices": [[0,0,0],[1,0,0],[1,1,0]], "triangles": [[0,1,2]],
        "material": {"base_color": {"texture": "albedo.png", "extension": "clip"}}}]})", tex_dir().string(), "tex.json");
  }, "tex.json", {"extension"});
}

TEST(Texture, PlyUvsAndTangents) {
  const std::string path = (tex_dir() / "uv.ply").string();
  std::ofstream(path) << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                         "property float s\nproperty float t\nproperty float tx\nproperty float ty\nproperty float tz\n"
                         "property float tw\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                         "0 0 0 0 0 1 0 0 1\n1 0 0 1 0 1 0 0 1\n0 1 0 0 1 1 0 0 -1\n3 0 1 2\n";
  const TriangleMesh m = load_mesh(path);
  ASSERT_EQ(m.uvs.size(), 3u);
  const Uv uv = m.uv_at(0, 0.5f, 0.25f);
  EXPECT_NEAR(uv.u, 0.5f, 1e-6f);
  EXPECT_NEAR(uv.v, 0.25f, 1e-6f);
  ASSERT_EQ(m.tangents.size(), 3u);
  EXPECT_EQ(m.tangent_signs[2], -1.0f);
}

TEST(Texture, BumpShadowingScalesTheDiffuseLobeOnly) {
  // A closure normal tilted 30 degrees from the surface's own (a normal map): light the surface
  // turns away from reaches the specular lobe only; light on its unshadowed side sees no change.
  MaterialParams p;
  p.albedo = Vec3(0.6f, 0.5f, 0.4f);
  p.roughness = 0.4f;
  const Vec3 wo = normalize(Vec3(0.2f, 0.1f, 1.0f));
  const Vec3 ns = normalize(Vec3(std::sin(0.5236f), 0.0f, std::cos(0.5236f)));  // own normal, closure frame
  {
    const BsdfKind kind = BsdfKind::PrincipledGGX;  // Blender 3.x's term (v2's: the next test)
    const Bsdf plain(kind, p, wo);
    Bsdf bumped(kind, p, wo);
    bumped.set_bump_shadowing(ns);
    const Vec3 behind = normalize(Vec3(-0.9f, 0.0f, 0.3f));  // above the closure's normal, behind ns
    ASSERT_LT(dot(behind, ns), 0.0f);
    const Vec3 lit = normalize(Vec3(0.5f, 0.2f, 1.0f));  // g >= 1: unshadowed
    EXPECT_GE(dot(lit, ns) / (dot(lit, Vec3(0, 0, 1)) * dot(ns, Vec3(0, 0, 1))), 1.0f);
    expect_vec(bumped.eval(lit), plain.eval(lit), 0.0f);
    const Vec3 f = bumped.eval(behind), full = plain.eval(behind);
    EXPECT_LT(max_component(f), max_component(full));  // the diffuse part is gone
    EXPECT_GT(max_component(f), 0.0f);                  // the specular part stays
    // Between: the smooth step -g^3 + g^2 + g of g = (ns.wi) / ((n.wi)(ns.n)).
    const Vec3 mid = normalize(Vec3(-0.3f, 0.0f, 1.0f));
    const float g = dot(ns, mid) / (mid.z * ns.z);
    ASSERT_GT(g, 0.0f);
    ASSERT_LT(g, 1.0f);
    EXPECT_NEAR(Bsdf::bump_shadowing(ns, Vec3(0, 0, 1), mid), -g * g * g + g * g + g, 1e-6f);
  }
}

TEST(Texture, BumpShadowingUnderV2IsBlender4sMicrofacetTerm) {
  // Blender 4.x: G1_GGX(wi about Ns) with alpha^2 = tan^2(30 deg) / 8, on every side Ns lights;
  // 0 behind it. Closed form: G1 = 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_i)).
  MaterialParams p;
  p.albedo = Vec3(0.6f, 0.5f, 0.4f);
  p.roughness = 0.4f;
  const Vec3 wo = normalize(Vec3(0.2f, 0.1f, 1.0f));
  const Vec3 ns = normalize(Vec3(std::sin(0.5236f), 0.0f, std::cos(0.5236f)));
  const Bsdf plain(BsdfKind::PrincipledV2GGX, p, wo);
  Bsdf bumped(BsdfKind::PrincipledV2GGX, p, wo);
  bumped.set_bump_shadowing(ns);
  const double alpha2 = std::pow(std::tan(0.5236), 2) / 8.0;
  for (const Vec3 wi : {normalize(Vec3(0.5f, 0.2f, 1.0f)), normalize(Vec3(-0.3f, 0.0f, 1.0f)),
                        normalize(Vec3(-0.6f, 0.3f, 0.8f))}) {
    const double ci = dot(ns, wi), t2 = 1.0 / (ci * ci) - 1.0;
    const double g1 = 2.0 / (1.0 + std::sqrt(1.0 + alpha2 * t2));
    EXPECT_NEAR(Bsdf::bump_shadowing_microfacet(ns, Vec3(0, 0, 1), wi), g1, 1e-5);
    EXPECT_LT(g1, 1.0);  // unlike Blender 3.x's, it shades the lit side too
  }
  const Vec3 behind = normalize(Vec3(-0.9f, 0.0f, 0.3f));
  EXPECT_EQ(Bsdf::bump_shadowing_microfacet(ns, Vec3(0, 0, 1), behind), 0.0f);
  EXPECT_LT(max_component(bumped.eval(behind)), max_component(plain.eval(behind)));  // diffuse gone
  EXPECT_GT(max_component(bumped.eval(behind)), 0.0f);                               // specular stays
}
