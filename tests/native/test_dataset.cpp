// Dataset reading: NeRF-synthetic and TensoIR layouts, image encodings, optional
// ground-truth and prior maps, and the errors for broken datasets.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ptir/core/error.h"
#include "ptir/scene/dataset.h"
#include "ptir/io/image.h"

namespace fs = std::filesystem;
using namespace ptir;

namespace {

fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::path(PTIR_TEST_TMP) / "dataset" / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// An 8-bit PNG with exactly these bytes (channels 1..4; alpha stored unassociated).
void write_png_bytes(const fs::path& path, int w, int h, int nc, const std::vector<unsigned char>& bytes) {
  fs::create_directories(path.parent_path());
  auto out = OIIO::ImageOutput::create(path.string());
  ASSERT_TRUE(out);
  OIIO::ImageSpec spec(w, h, nc, OIIO::TypeDesc::UINT8);
  if (nc == 4) spec.alpha_channel = 3;
  spec.attribute("oiio:UnassociatedAlpha", 1);
  ASSERT_TRUE(out->open(path.string(), spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, bytes.data()));
  out->close();
}

// A w x h RGBA PNG: pixel (x, y) = (10 x, 20 y, 200, alpha) with alpha 255 except (0, 0) = 128.
void write_view_png(const fs::path& path, int w, int h) {
  std::vector<unsigned char> b(size_t(w) * h * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      unsigned char* p = &b[(size_t(y) * w + x) * 4];
      p[0] = (unsigned char)(10 * x);
      p[1] = (unsigned char)(20 * y);
      p[2] = 200;
      p[3] = (x == 0 && y == 0) ? 128 : 255;
    }
  write_png_bytes(path, w, h, 4, b);
}

void write_grey_png(const fs::path& path, int w, int h, unsigned char v) {
  write_png_bytes(path, w, h, 1, std::vector<unsigned char>(size_t(w) * h, v));
}

const char* kMatrix = "[[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]";

void write_transforms(const fs::path& path, const std::vector<std::string>& file_paths, const std::string& extra = "") {
  std::ofstream out(path);
  out << "{\"camera_angle_x\": 0.69" << extra << ", \"frames\": [";
  for (size_t i = 0; i < file_paths.size(); ++i)
    out << (i ? "," : "") << "{\"file_path\": \"" << file_paths[i] << "\", \"transform_matrix\": " << kMatrix << "}";
  out << "]}";
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Dataset, TensoIRLayoutWithoutExtensionsAndGroundTruth) {
  fs::path d = fresh_dir("tensoir");
  for (int i = 0; i < 2; ++i) {
    fs::path v = d / ("train_00" + std::to_string(i));
    write_view_png(v / "rgba.png", 6, 4);
    write_view_png(v / "albedo.png", 6, 4);
    write_grey_png(v / "roughness.png", 6, 4, 51);
  }
  write_grey_png(d / "train_000" / "normal.png", 6, 4, 255);
  write_transforms(d / "transforms_train.json", {"./train_000/rgba", "./train_001/rgba"});

  auto data = load_dataset(d.string());
  ASSERT_EQ(data->size(), 2u);
  EXPECT_EQ(data->width, 6);
  EXPECT_EQ(data->height, 4);
  EXPECT_EQ(data->split, "train");
  EXPECT_EQ(data->views[0].camera.name, "train_000");
  EXPECT_EQ(fs::path(data->views[1].files.image).filename(), "rgba.png");
  EXPECT_FALSE(data->views[0].files.gt_albedo.empty());
  EXPECT_FALSE(data->views[0].files.gt_normal.empty());
  EXPECT_TRUE(data->views[1].files.gt_normal.empty());
  EXPECT_FALSE(data->has_priors());

  auto t = data->target(1);
  ASSERT_TRUE(t->has_alpha);
  // sRGB decoding of the straight (unassociated) colour, alpha as the mask.
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 6; ++x) {
      EXPECT_NEAR(t->rgb.at(x, y, 0), srgb_to_linear(10 * x / 255.0f), 1e-6f);
      EXPECT_NEAR(t->rgb.at(x, y, 1), srgb_to_linear(20 * y / 255.0f), 1e-6f);
      EXPECT_NEAR(t->rgb.at(x, y, 2), srgb_to_linear(200 / 255.0f), 1e-6f);
      EXPECT_NEAR(t->alpha.at(x, y, 0), (x == 0 && y == 0) ? 128 / 255.0f : 1.0f, 1e-6f);
    }
  // Cached: the same object again.
  EXPECT_EQ(data->target(1).get(), t.get());

  Image alb = data->gt_albedo(0);
  ASSERT_EQ(alb.channels, 3);
  EXPECT_NEAR(alb.at(3, 2, 2), srgb_to_linear(200 / 255.0f), 1e-6f);
  Image r = data->gt_roughness(0);
  ASSERT_EQ(r.channels, 1);
  EXPECT_NEAR(r.at(5, 3, 0), 0.2f, 1e-6f);  // data, not sRGB
  Image n = data->gt_normal(0);
  EXPECT_NEAR(n.at(0, 0, 0), 1.0f, 1e-6f);  // 8-bit normals: 2 v - 1
  EXPECT_EQ(data->gt_normal(1).width, 0);   // absent
}

TEST(Dataset, NerfSyntheticLayoutExrAndPriors) {
  fs::path d = fresh_dir("nerf");
  fs::create_directories(d / "train");
  // EXR: linear, associated alpha -> un-premultiplied.
  Image img(3, 2, {"R", "G", "B", "A"});
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      float a = x == 2 ? 0.5f : 1.0f;
      img.at(x, y, 0) = 2.0f * a;
      img.at(x, y, 1) = 0.25f * a;
      img.at(x, y, 2) = 0.0f;
      img.at(x, y, 3) = a;
    }
  write_image((d / "train" / "r_0.exr").string(), img);
  Image rough(3, 2, {"Y"});
  for (float& v : rough.pixels) v = 0.35f;
  write_image((d / "train" / "r_0_roughness.exr").string(), rough, Encoding::Data);
  fs::path prior = d / "prior";
  write_view_png(prior / "train" / "r_0_albedo.png", 3, 2);
  write_transforms(d / "transforms_test.json", {"./train/r_0.exr"});

  // The split picks the file; a transforms file can be given directly too.
  EXPECT_NE(error_of([&] { load_dataset(d.string()); }).find("no transforms_train.json"), std::string::npos);
  DatasetOptions o;
  o.split = "test";
  o.prior_dir = prior.string();
  auto data = load_dataset(d.string(), o);
  ASSERT_EQ(data->size(), 1u);
  EXPECT_EQ(data->views[0].camera.name, "r_0");
  auto t = data->target(0);
  EXPECT_NEAR(t->rgb.at(2, 1, 0), 2.0f, 1e-6f);
  EXPECT_NEAR(t->rgb.at(2, 1, 1), 0.25f, 1e-6f);
  EXPECT_NEAR(t->alpha.at(2, 1, 0), 0.5f, 1e-6f);
  EXPECT_NEAR(data->gt_roughness(0).at(1, 1, 0), 0.35f, 1e-6f);
  EXPECT_TRUE(data->has_priors());
  EXPECT_EQ(data->prior_albedo(0).width, 3);
  EXPECT_EQ(data->prior_roughness(0).width, 0);

  auto direct = load_dataset((d / "transforms_test.json").string());
  EXPECT_EQ(direct->split, "test");
  EXPECT_EQ(direct->size(), 1u);
}

TEST(Dataset, ImageWithoutAlphaIsUnmasked) {
  fs::path d = fresh_dir("rgb");
  std::vector<unsigned char> b(4 * 4 * 3, 255);
  write_png_bytes(d / "a.png", 4, 4, 3, b);
  write_transforms(d / "transforms_train.json", {"a"});
  auto t = load_dataset(d.string())->target(0);
  EXPECT_FALSE(t->has_alpha);
  EXPECT_FLOAT_EQ(t->alpha.at(2, 2, 0), 1.0f);
  EXPECT_NEAR(t->rgb.at(2, 2, 1), 1.0f, 1e-6f);
}

TEST(Dataset, ClearErrors) {
  fs::path d = fresh_dir("errors");
  // Missing folder / transforms.
  EXPECT_NE(error_of([&] { load_dataset((d / "nope").string()); }).find("dataset folder not found"), std::string::npos);
  EXPECT_NE(error_of([&] { load_dataset(d.string()); }).find("no transforms_*.json at all"), std::string::npos);

  // Bad JSON names the file.
  { std::ofstream(d / "transforms_train.json") << "{\"camera_angle_x\": 0.5, \"frames\": [ {]"; }
  std::string e = error_of([&] { load_dataset(d.string()); });
  EXPECT_NE(e.find("transforms_train.json"), std::string::npos) << e;
  EXPECT_NE(e.find("invalid JSON"), std::string::npos) << e;

  // A missing image names the frame and the path tried.
  write_view_png(d / "train_000" / "rgba.png", 6, 4);
  write_transforms(d / "transforms_train.json", {"./train_000/rgba", "./train_001/rgba"}, ", \"w\": 6, \"h\": 4");
  e = error_of([&] { load_dataset(d.string()); });
  EXPECT_NE(e.find("frames[1]"), std::string::npos) << e;
  EXPECT_NE(e.find("train_001/rgba"), std::string::npos) << e;
  EXPECT_NE(e.find("not found"), std::string::npos) << e;

  // Size mismatch between views.
  write_view_png(d / "train_001" / "rgba.png", 5, 4);
  e = error_of([&] { load_dataset(d.string()); });
  EXPECT_NE(e.find("train_001/rgba.png"), std::string::npos) << e;
  EXPECT_NE(e.find("5x4"), std::string::npos) << e;

  // Size mismatch of a ground-truth map.
  write_view_png(d / "train_001" / "rgba.png", 6, 4);
  write_grey_png(d / "train_001" / "roughness.png", 3, 4, 10);
  e = error_of([&] { load_dataset(d.string()); });
  EXPECT_NE(e.find("roughness.png"), std::string::npos) << e;
  EXPECT_NE(e.find("3x4"), std::string::npos) << e;
  fs::remove(d / "train_001" / "roughness.png");

  // A prior folder without any prior map.
  fs::create_directories(d / "empty_prior");
  DatasetOptions o;
  o.prior_dir = (d / "empty_prior").string();
  e = error_of([&] { load_dataset(d.string(), o); });
  EXPECT_NE(e.find("no prior maps"), std::string::npos) << e;

  // A frame without file_path.
  { std::ofstream(d / "transforms_val.json") << "{\"camera_angle_x\": 0.5, \"w\": 6, \"h\": 4, \"frames\": [{\"transform_matrix\": " << kMatrix << "}]}"; }
  o = DatasetOptions();
  o.split = "val";
  e = error_of([&] { load_dataset(d.string(), o); });
  EXPECT_NE(e.find("file_path"), std::string::npos) << e;

  // An unreadable image.
  { std::ofstream(d / "train_000" / "rgba.png") << "not a png"; }
  e = error_of([&] { load_dataset(d.string()); });
  EXPECT_NE(e.find("train_000/rgba.png"), std::string::npos) << e;
}

TEST(Dataset, PixelFilterFromDatasetJson) {
  fs::path d = fresh_dir("filter");
  std::vector<unsigned char> b(4 * 4 * 3, 128);
  write_png_bytes(d / "a.png", 4, 4, 3, b);
  write_transforms(d / "transforms_train.json", {"a"});
  // No dataset.json: unset, rendered with Blender's default.
  auto none = load_dataset(d.string());
  EXPECT_FALSE(none->pixel_filter.has_value());
  EXPECT_EQ(dataset_pixel_filter(*none).type, PixelFilterType::BlackmanHarris);
  EXPECT_FLOAT_EQ(dataset_pixel_filter(*none).width, 1.5f);
  // The structured record, and the older text of scripts/make_dataset.py.
  std::ofstream(d / "dataset.json") << R"({"cycles": {"pixel_filter": {"type": "gaussian", "width": 2.0}}})";
  auto g = load_dataset(d.string());
  ASSERT_TRUE(g->pixel_filter.has_value());
  EXPECT_EQ(g->pixel_filter->type, PixelFilterType::Gaussian);
  EXPECT_FLOAT_EQ(g->pixel_filter->width, 2.0f);
  std::ofstream(d / "dataset.json") << R"({"cycles": {"spp": 64, "pixel_filter": "box 1px"}})";
  auto box = load_dataset(d.string());
  EXPECT_EQ(box->pixel_filter->type, PixelFilterType::Box);
  EXPECT_FLOAT_EQ(box->pixel_filter->width, 1.0f);
  // Other makers' dataset.json without the entry: unset.
  std::ofstream(d / "dataset.json") << R"({"format": "x"})";
  EXPECT_FALSE(load_dataset(d.string())->pixel_filter.has_value());
  // Malformed: an error naming the file.
  std::ofstream(d / "dataset.json") << R"({"cycles": {"pixel_filter": {"type": "mitchell", "width": 1}}})";
  std::string e = error_of([&] { load_dataset(d.string()); });
  EXPECT_NE(e.find("dataset.json"), std::string::npos) << e;
  EXPECT_NE(e.find("mitchell"), std::string::npos) << e;
  std::ofstream(d / "dataset.json") << R"({"cycles": {"pixel_filter": 3}})";
  EXPECT_NE(error_of([&] { load_dataset(d.string()); }).find("dataset.json"), std::string::npos);
}
