// COLMAP models and lens models: a real reconstruction's 3D points reproject onto
// their recorded 2D observations through our reader, pose convention and lens
// (tests/data/colmap_beer, SIMPLE_RADIAL); text and binary files agree; the lens
// inverse is the inverse; bad files fail with the file's name.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "ptir/core/error.h"
#include "ptir/scene/colmap_model.h"
#include "ptir/scene/dataset_layouts.h"
#include "ptir/scene/lens_model.h"
#include "ptir/scene/undistort.h"

namespace fs = std::filesystem;
using namespace ptir;

namespace {

// This file's folder: __FILE__ may be relative to the test objects' build folder
// (<build>/tests) when the compiler launcher rewrites paths (ccache's base_dir).
fs::path tests_dir() {
  fs::path f(__FILE__);
  if (f.is_relative()) f = fs::path(PTIR_TEST_TMP).parent_path() / "tests" / f;
  return f.lexically_normal().parent_path().parent_path();
}
const fs::path kBeer = tests_dir() / "data" / "colmap_beer";

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::path(PTIR_TEST_TMP) / "colmap" / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// Pixel of world point X through our camera-to-world (row-major 3x4, camera looks
// down -z, +y up) and a lens in COLMAP's image convention.
Point2d project(const std::array<double, 12>& c2w, const LensModel& lens, const std::array<double, 3>& X) {
  double d[3] = {X[0] - c2w[3], X[1] - c2w[7], X[2] - c2w[11]};
  double p[3];
  for (int a = 0; a < 3; ++a) p[a] = c2w[0 + size_t(a)] * d[0] + c2w[4 + size_t(a)] * d[1] + c2w[8 + size_t(a)] * d[2];
  // Ours -> COLMAP camera axes: (x, -y, -z).
  const double z = -p[2];
  return lens.image_from_camera({p[0] / z, -p[1] / z});
}

}  // namespace

TEST(Colmap, RealModelPointsReprojectOntoTheirObservations) {
  const std::string dir = find_colmap_model(kBeer.string());
  ASSERT_EQ(dir, (kBeer / "sparse" / "0").lexically_normal().string());
  const ColmapModel m = read_colmap_model(dir, true, true);
  ASSERT_EQ(m.images.size(), 8u);
  ASSERT_EQ(m.points.size(), 670u);
  std::map<uint32_t, const ColmapImage*> by_id;
  for (const ColmapImage& im : m.images) by_id[im.id] = &im;
  double sum = 0, recorded = 0, worst = 0;
  size_t n = 0;
  for (const ColmapPoint& pt : m.points) {
    recorded += pt.error;
    for (const auto& [iid, k] : pt.track) {
      const ColmapImage& im = *by_id.at(iid);
      const ColmapCamera& cam = m.cameras.at(im.camera_id);
      ASSERT_EQ(cam.model, "SIMPLE_RADIAL");
      const LensModel lens = lens_from_colmap(cam.model, cam.params, cam.width, cam.height, "beer");
      const Point2d uv = project(cam_to_world_from_colmap(im.q, im.t), lens, pt.xyz);
      ASSERT_LT(k, im.xy.size());
      ASSERT_EQ(im.point3d_id[k], int64_t(pt.id));
      const double e = std::hypot(uv[0] - im.xy[k][0], uv[1] - im.xy[k][1]);
      sum += e;
      worst = std::max(worst, e);
      ++n;
    }
  }
  const double mean = sum / double(n), recorded_mean = recorded / double(m.points.size());
  std::printf("beer: %zu observations, mean reprojection error %.4f px (COLMAP recorded %.4f), worst %.3f px\n", n, mean,
              recorded_mean, worst);
  // COLMAP filters observations above 4 px; the kept tracks' mean is the recorded mean within 10%.
  EXPECT_LT(worst, 4.0);
  EXPECT_LT(mean, 1.1 * recorded_mean);
  EXPECT_GT(mean, 0.5 * recorded_mean);  // a test that could not fail would not be a test
}

TEST(Colmap, TextAndBinaryAgree) {
  // Write the binary fixture's cameras/images as text by hand, then read both.
  const ColmapModel b = read_colmap_model((kBeer / "sparse" / "0").string(), true, false);
  const fs::path d = fresh_dir("text");
  {
    std::ofstream c(d / "cameras.txt");
    c.precision(17);
    c << "# comment\n";
    for (const auto& [id, cam] : b.cameras) {
      c << id << " " << cam.model << " " << cam.width << " " << cam.height;
      for (double p : cam.params) c << " " << p;
      c << "\n";
    }
    std::ofstream i(d / "images.txt");
    i.precision(17);
    for (const ColmapImage& im : b.images) {
      i << im.id << " " << im.q[0] << " " << im.q[1] << " " << im.q[2] << " " << im.q[3] << " " << im.t[0] << " " << im.t[1]
        << " " << im.t[2] << " " << im.camera_id << " " << im.name << "\n";
      for (size_t k = 0; k < im.xy.size(); ++k) i << im.xy[k][0] << " " << im.xy[k][1] << " " << im.point3d_id[k] << " ";
      i << "\n";
    }
  }
  const ColmapModel t = read_colmap_model(d.string(), true, false);
  ASSERT_FALSE(t.binary);
  ASSERT_EQ(t.images.size(), b.images.size());
  for (size_t k = 0; k < b.images.size(); ++k) {
    EXPECT_EQ(t.images[k].name, b.images[k].name);
    EXPECT_EQ(t.images[k].q, b.images[k].q);
    EXPECT_EQ(t.images[k].t, b.images[k].t);
    EXPECT_EQ(t.images[k].xy, b.images[k].xy);
    EXPECT_EQ(t.images[k].point3d_id, b.images[k].point3d_id);
  }
  for (const auto& [id, cam] : b.cameras) EXPECT_EQ(t.cameras.at(id).params, cam.params);
}

TEST(Colmap, LensInverseIsTheInverse) {
  const std::vector<std::pair<std::string, std::vector<double>>> lenses = {
      {"SIMPLE_RADIAL", {500, 320, 240, -0.12}},
      {"RADIAL", {500, 320, 240, -0.2, 0.05}},
      {"OPENCV", {510, 495, 318, 244, -0.25, 0.08, 0.001, -0.0007}},
      {"FULL_OPENCV", {510, 495, 318, 244, -0.25, 0.08, 0.001, -0.0007, 0.01, 0.02, 0.003, 0.001}},
      {"OPENCV_FISHEYE", {300, 300, 320, 240, 0.05, -0.01, 0.002, -0.0005}}};
  for (const auto& [model, params] : lenses) {
    const LensModel l = lens_from_colmap(model, params, 640, 480, model);
    EXPECT_TRUE(l.distorted()) << model;
    double worst = 0;
    for (double v = 0.5; v < 480; v += 31.7)
      for (double u = 0.5; u < 640; u += 29.3) {
        const Point2d x = l.camera_from_image({u, v});
        const Point2d back = l.image_from_camera(x);
        worst = std::max(worst, std::hypot(back[0] - u, back[1] - v));
      }
    EXPECT_LT(worst, 1e-6) << model;
    // The undistorted window is inside the image's undistorted border, non-empty.
    const PinholeWindow w = plan_undistortion(l, model);
    EXPECT_GT(w.width, 320) << model;
    EXPECT_GT(w.height, 240) << model;
  }
  // An undistorted lens keeps the whole image and its intrinsics.
  const PinholeWindow w = plan_undistortion(lens_from_colmap("PINHOLE", {500, 510, 300, 200}, 640, 480, "p"), "p");
  EXPECT_EQ(w.width, 640);
  EXPECT_EQ(w.height, 480);
  EXPECT_EQ(w.cx, 300);
  EXPECT_EQ(w.cy, 200);
}

TEST(Colmap, ErrorsNameTheFileAndProblem) {
  const fs::path d = fresh_dir("bad");
  auto expect_error = [](const std::string& dir, const std::string& part) {
    try {
      read_colmap_model(dir, true, true);
      ADD_FAILURE() << "no error for " << part;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  expect_error(d.string(), "has no cameras.bin or cameras.txt");
  std::ofstream(d / "cameras.txt") << "1 PINHOLE 640 480 500 500 320\n";
  std::ofstream(d / "images.txt") << "";
  expect_error(d.string(), "cameras.txt: line 1: PINHOLE needs 4 parameters, got 3");
  std::ofstream(d / "cameras.txt") << "1 FOV 640 480 500 500 320 240 0.1\n";
  EXPECT_THROW(lens_from_colmap("FOV", {500, 500, 320, 240, 0.1}, 640, 480, "x"), Error);
  std::ofstream(d / "cameras.txt") << "1 PINHOLE 640 480 500 500 320 240\n";
  std::ofstream(d / "images.txt") << "1 1 0 0 0 0 0 0 7 a.png\n\n";
  expect_error(d.string(), "refers to camera 7");
  std::ofstream(d / "images.txt") << "1 1 0 0 0 0 0 0 1 a.png\n\n";
  std::ofstream(d / "points3D.txt") << "1 0 0 0 255 255 255 0.5 1 0\n";
  EXPECT_NO_THROW(read_colmap_model(d.string(), true, true));
  // Truncated binary file.
  fs::remove(d / "cameras.txt");
  {
    std::ofstream c(d / "cameras.bin", std::ios::binary);
    const uint64_t n = 1;
    c.write(reinterpret_cast<const char*>(&n), 8);
    const int32_t id = 1, model = 1;
    c.write(reinterpret_cast<const char*>(&id), 4);
    c.write(reinterpret_cast<const char*>(&model), 4);
  }
  expect_error(d.string(), "cameras.bin: truncated file");
}
