// Mesh loading: PLY and OBJ quads, OBJ index forms, range and format errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>

#include "ptir/core/error.h"
#include "ptir/scene/mesh.h"
#include "expect_error.h"

using namespace ptir;

namespace {

std::string mesh_tmp(const std::string& name, const std::string& contents) {
  const std::filesystem::path dir = std::filesystem::path(PTIR_TEST_TMP) / "mesh_io";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << contents;
  return path;
}

void expect_mesh_error(const std::string& path, std::initializer_list<std::string> phrases) {
  test::expect_error([&] { load_mesh(path); }, path, phrases);
}

const std::string kQuadPlyHeader =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty float y\nproperty float z\n"
    "property uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n";

void expect_quad(const TriangleMesh& m) {
  ASSERT_EQ(m.vertices.size(), 4u);
  ASSERT_EQ(m.triangles.size(), 2u);
  EXPECT_EQ(m.triangles[0], (std::array<uint32_t, 3>{0, 1, 2}));
  EXPECT_EQ(m.triangles[1], (std::array<uint32_t, 3>{0, 2, 3}));
  EXPECT_FLOAT_EQ(m.vertices[2].x, 1.0f);
  EXPECT_FLOAT_EQ(m.vertices[2].y, 1.0f);
  EXPECT_NEAR(m.face_normal(0).z, 1.0f, 1e-6);
}

}  // namespace

TEST(MeshIo, PlyQuadIsTwoTriangles) {
  const TriangleMesh m = load_mesh(mesh_tmp("quad.PLY", kQuadPlyHeader + "4 0 1 2 3\n"));
  expect_quad(m);
  EXPECT_EQ(m.name, "quad");
  // "vertex_index" is accepted too.
  std::string alt = kQuadPlyHeader;
  alt.replace(alt.find("vertex_indices"), 14, "vertex_index");
  expect_quad(load_mesh(mesh_tmp("quad_alt.ply", alt + "4 0 1 2 3\n")));
}

TEST(MeshIo, PlyErrors) {
  expect_mesh_error(mesh_tmp("range.ply", kQuadPlyHeader + "4 0 1 2 4\n"), {"face 0 refers to vertex 4", "4 vertices"});
  expect_mesh_error(mesh_tmp("neg.ply", kQuadPlyHeader + "3 0 -1 2\n"), {"refers to vertex -1"});
  expect_mesh_error(mesh_tmp("points.ply",
                             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                             "property float z\nend_header\n0 0 0\n"),
                    {"no 'face' element"});
  expect_mesh_error(mesh_tmp("lines.ply", kQuadPlyHeader + "2 0 1\n"), {"no triangles"});
}

TEST(MeshIo, ObjQuadAndIndexForms) {
  const std::string verts = "# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
  expect_quad(load_mesh(mesh_tmp("plain.obj", verts + "f 1 2 3 4\n")));
  expect_quad(
      load_mesh(mesh_tmp("slashes.obj", verts + "o thing\ng group\nusemtl m\ns off\nf 1/1/1 2/1/1 3/1/1 4/1/1\n")));
  expect_quad(load_mesh(mesh_tmp("vt.obj", verts + "f 1/1 2/1 3/1 4/1\n")));
  expect_quad(load_mesh(mesh_tmp("vn.OBJ", verts + "f 1//1 2//1 3//1 4//1\r\n")));
  const TriangleMesh neg = load_mesh(mesh_tmp("negative.obj", verts + "f -4 -3 -2 -1\n"));
  expect_quad(neg);
  EXPECT_EQ(neg.name, "negative");
}

TEST(MeshIo, ObjErrors) {
  const std::string verts = "v 0 0 0\nv 1 0 0\nv 1 1 0\n";
  expect_mesh_error(mesh_tmp("range.obj", verts + "f 1 2 4\n"),
                    {"line 4", "face index 4 is out of range", "3 vertices"});
  expect_mesh_error(mesh_tmp("negrange.obj", verts + "f -1 -2 -4\n"), {"line 4", "face index -4 is out of range"});
  expect_mesh_error(mesh_tmp("zero.obj", verts + "f 0 1 2\n"), {"line 4", "bad face index '0'"});
  expect_mesh_error(mesh_tmp("word.obj", verts + "f a b c\n"), {"bad face index 'a'"});
  expect_mesh_error(mesh_tmp("badv.obj", "v 0 0\n"), {"line 1", "bad vertex"});
  expect_mesh_error(mesh_tmp("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), {"vertex 0", "NaN"});
  expect_mesh_error(mesh_tmp("noface.obj", verts), {"no triangles"});
  expect_mesh_error(mesh_tmp("mesh.stl", "solid x\n"), {"unsupported mesh format '.stl'"});
  const std::filesystem::path missing = std::filesystem::path(PTIR_TEST_TMP) / "mesh_io" / "missing.obj";
  expect_mesh_error(missing.string(), {"cannot open file"});
}

// Vertex normals (nx, ny, nz): read, normalised, interpolated with Embree's barycentrics (u, v: the
// weights of corners 1 and 2); without them, and where they cancel, the face normal.
TEST(MeshIo, PlyVertexNormalsInterpolate) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  const TriangleMesh m = load_mesh(mesh_tmp("smooth.ply", header + "0 0 0 0 0 2\n1 0 0 1 0 1\n0 1 0 0 1 1\n3 0 1 2\n"));
  ASSERT_TRUE(m.smooth());
  EXPECT_NEAR(m.normals[0].z, 1.0f, 1e-6);  // normalised on load
  const float s = 1.0f / std::sqrt(2.0f);
  // At corner 1: its normal; halfway along edge 1-2: the normalised mean of (1, 0, 1) and (0, 1, 1).
  EXPECT_NEAR(m.shading_normal(0, 1.0f, 0.0f).x, s, 1e-6);
  const Vec3 mid = m.shading_normal(0, 0.5f, 0.5f);
  const float len = std::sqrt(0.25f + 0.25f + 1.0f);
  EXPECT_NEAR(mid.x, 0.5f / len, 1e-6);
  EXPECT_NEAR(mid.z, 1.0f / len, 1e-6);
  expect_mesh_error(mesh_tmp("zero_normal.ply", header + "0 0 0 0 0 0\n1 0 0 1 0 1\n0 1 0 0 1 1\n3 0 1 2\n"),
                    {"vertex 0 has a zero or non-finite normal"});
  std::string partial = header;
  partial.replace(partial.find("property float nz\n"), 18, "");
  expect_mesh_error(mesh_tmp("partial_normal.ply", partial + "0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 1 2\n"),
                    {"need all of nx, ny, nz"});
  // No normals: the face normal.
  const TriangleMesh flat = load_mesh(mesh_tmp("flat.ply", kQuadPlyHeader + "4 0 1 2 3\n"));
  EXPECT_FALSE(flat.smooth());
  EXPECT_NEAR(flat.shading_normal(0, 0.3f, 0.3f).z, 1.0f, 1e-6);
}
