#include "optimizer_fixture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "ptir/io/image.h"
#include "ptir/render/render_path.h"
#include "test_scenes.h"

namespace fs = std::filesystem;

namespace ptir::test {

// Under a folder named after the running test: ctest runs tests as parallel
// processes, and one must not remove the files another is reading.
fs::path fresh_dir(const std::string& name) {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::string test = info ? std::string(info->test_suite_name()) + "." + info->name() : "no_test";
  fs::path d = fs::path(PTIR_TEST_TMP) / "optimizer" / test / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

Camera look_at(Vec3 eye, Vec3 target, int res, const std::string& name) {
  Vec3 back = normalize(eye - target);
  Vec3 right = normalize(cross(Vec3(0, 0, 1), back));
  Vec3 up = cross(back, right);
  float m[16] = {right.x, up.x, back.x, eye.x, right.y, up.y, back.y, eye.y, right.z, up.z, back.z, eye.z, 0, 0, 0, 1};
  return make_camera(m, 0.7f, res, res, name);
}

Environment sky(int w, int h) {
  Image img(w, h, {"R", "G", "B"});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float t = float(y) / float(h - 1);
      img.at(x, y, 0) = 1.5f - 1.0f * t;
      img.at(x, y, 1) = 1.4f - 0.8f * t;
      img.at(x, y, 2) = 1.2f - 0.4f * t;
    }
  img.at(w / 4, 1, 0) = 6.0f;
  img.at(w / 4, 1, 1) = 5.0f;
  img.at(w / 4, 1, 2) = 4.0f;
  return Environment(img);
}

GaussianField truth_field(size_t n) {
  GaussianField f = test::gaussian_sphere(n, 1.0f, Vec3(0.3f), 0.6f, 0.0f, 0.95f);
  for (size_t i = 0; i < n; ++i) {
    bool top = f.position[i].z > 0;
    f.albedo[i] = top ? Vec3(0.7f, 0.35f, 0.2f) : Vec3(0.2f, 0.45f, 0.7f);
    f.roughness[i] = top ? 0.3f : 0.7f;
  }
  return f;
}

std::shared_ptr<const Dataset> make_dataset(const fs::path& dir, size_t n, int views, int res, int spp) {
  Scene truth;
  truth.gaussians = std::make_shared<GaussianField>(truth_field(n));
  truth.environment = sky();
  PathTracer tracer(truth);
  IntegratorSettings s;
  s.spp = spp;
  s.max_bounces = 1;
  std::ostringstream js;
  js << "{\"camera_angle_x\": 0.7, \"frames\": [";
  for (int i = 0; i < views; ++i) {
    float phi = 2.0f * kPi * float(i) / float(views);
    Vec3 eye(3.5f * std::cos(phi), 3.5f * std::sin(phi), (i % 2) ? 1.6f : -0.8f);
    std::string name = "train_00" + std::to_string(i);
    Camera cam = look_at(eye, Vec3(0.0f), res, name);
    Image img = render_path(tracer, cam, s);
    for (int p = 0; p < res * res; ++p)
      for (int c = 0; c < 3; ++c) img.pixels[size_t(p) * 4 + c] *= img.pixels[size_t(p) * 4 + 3];  // EXR: associated alpha
    fs::create_directories(dir / name);
    write_image((dir / name / "rgba.exr").string(), img);
    const Affine& a = cam.cam_to_world;
    js << (i ? "," : "") << "{\"file_path\": \"./" << name << "/rgba\", \"transform_matrix\": [";
    for (int r = 0; r < 3; ++r)
      js << "[" << a.linear.m[r][0] << "," << a.linear.m[r][1] << "," << a.linear.m[r][2] << "," << a.translation[r] << "],";
    js << "[0,0,0,1]]}";
  }
  js << "]}";
  std::ofstream(dir / "transforms_train.json") << js.str();
  return std::shared_ptr<const Dataset>(load_dataset(dir.string()));
}

Scene input_scene(size_t n) {
  Scene s;
  GaussianField f = truth_field(n);
  std::fill(f.albedo.begin(), f.albedo.end(), Vec3(0.5f));  // forgotten by the optimiser anyway
  s.gaussians = std::make_shared<GaussianField>(std::move(f));
  return s;
}

OptimizerSettings small_settings() {
  OptimizerSettings s;
  s.integrator.spp = 2;
  s.integrator.max_bounces = 1;
  s.params.env_width = 16;
  s.params.env_height = 8;
  s.seed = 7;
  return s;
}

const OptimizerFixture& fixture() {
  static OptimizerFixture f = [] {
    OptimizerFixture x;
    x.data = make_dataset(fresh_dir("data"), x.n, 4, 24, 32);
    return x;
  }();
  return f;
}

}  // namespace ptir::test
