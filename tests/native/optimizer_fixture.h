// The inversion tests' scene: a sphere of Gaussians (warm top, cool bottom) under a
// sky with one hot texel, rendered from a few views into a TensoIR-layout dataset.
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include "ptir/lights/environment.h"
#include "ptir/optim/optimizer.h"
#include "ptir/scene/dataset.h"

namespace ptir::test {

// An empty folder PTIR_TEST_TMP/optimizer/<name>.
std::filesystem::path fresh_dir(const std::string& name);
Camera look_at(Vec3 eye, Vec3 target, int res, const std::string& name);
// A sky: brighter and bluer toward +z, one hot texel.
Environment sky(int w = 16, int h = 8);
// Ground truth: a sphere of n Gaussians, warm top, cool bottom.
GaussianField truth_field(size_t n);
// Renders `views` training views of the truth into `dir` (TensoIR layout, RGBA EXR)
// and returns the dataset.
std::shared_ptr<const Dataset> make_dataset(const std::filesystem::path& dir, size_t n, int views, int res, int spp);
// The truth's geometry with a uniform albedo.
Scene input_scene(size_t n);
// 2 spp, 1 bounce, a 16x8 environment, seed 7.
OptimizerSettings small_settings();

struct OptimizerFixture {
  std::shared_ptr<const Dataset> data;
  size_t n = 300;
};
// 4 views at 24^2 of 300 Gaussians, 32 spp; made once per process.
const OptimizerFixture& fixture();

}  // namespace ptir::test
