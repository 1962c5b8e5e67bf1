// Image files: a short or corrupt file is an error naming it (never an image with
// its tail missing), and writing is atomic (no temp left, the old file kept on
// failure).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "ptir/core/error.h"
#include "ptir/io/atomic_file.h"
#include "ptir/io/image.h"

using namespace ptir;
namespace fs = std::filesystem;

namespace {

fs::path image_tmp(const std::string& name) {
  const fs::path dir = fs::path(PTIR_TEST_TMP) / "image_io";
  fs::create_directories(dir);
  return dir / name;
}

std::string get_file(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

void put_file(const fs::path& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f << bytes;
}

// A 48x40 RGB gradient with a hash on top (so compressors cannot shrink it to nothing).
Image test_pattern() {
  Image img(48, 40, {"R", "G", "B"});
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const unsigned h = (unsigned(x) * 73856093u) ^ (unsigned(y) * 19349663u);
      img.at(x, y, 0) = float(x) / img.width;
      img.at(x, y, 1) = float(y) / img.height;
      img.at(x, y, 2) = float(h % 1000u) / 1000.0f;
    }
  return img;
}

bool no_temps_in(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".ptir-tmp-") != std::string::npos) return false;
  return true;
}

}  // namespace

// Each format cut at several lengths: the whole file reads back (the reference),
// every cut one is refused with the file's name. Before read_image checked
// has_error(), JPEG and TIFF cut anywhere past their headers came back as images.
TEST(ImageIo, TruncatedFilesAreErrors) {
  const Image img = test_pattern();
  for (const char* ext : {".png", ".jpg", ".tif", ".exr"}) {
    SCOPED_TRACE(ext);
    const fs::path whole = image_tmp(std::string("whole") + ext);
    write_image(whole.string(), img);
    const Image back = read_image(whole.string());
    ASSERT_EQ(back.width, img.width);
    ASSERT_EQ(back.height, img.height);
    const float tolerance = std::string(ext) == ".jpg" ? 0.2f : 0.01f;
    EXPECT_NEAR(back.at(17, 23, 0), img.at(17, 23, 0), tolerance);
    const std::string bytes = get_file(whole);
    for (double fraction : {0.2, 0.45, 0.59, 0.8, 0.95}) {
      SCOPED_TRACE(fraction);
      const fs::path cut = image_tmp(std::string("cut") + ext);
      put_file(cut, bytes.substr(0, size_t(fraction * double(bytes.size()))));
      try {
        read_image(cut.string());
        ADD_FAILURE() << "a file cut to " << fraction << " of its bytes was read without an error";
      } catch (const ptir::Error& e) {
        EXPECT_NE(std::string(e.what()).find(cut.string()), std::string::npos) << e.what();
      }
    }
  }
}

// An EXR header attribute declaring more bytes than the file holds (what fuzz_image
// found: OpenEXR allocated a 1.7 GB string for an 86-byte file) is refused by name
// before OpenEXR reads it; a real EXR's header, with every attribute in the file,
// still reads. The huge size is put on the first attribute of a real file.
TEST(ImageIo, ExrHeaderAttributesMustFitTheFile) {
  const fs::path whole = image_tmp("header_whole.exr");
  write_image(whole.string(), test_pattern());
  std::string bytes = get_file(whole);
  ASSERT_NO_THROW(read_image(whole.string()));
  const size_t type_end = bytes.find('\0', bytes.find('\0', 8) + 1);  // after the first name and type
  ASSERT_LT(type_end + 4, bytes.size());
  for (int k = 0; k < 4; ++k) bytes[type_end + 1 + k] = char(k == 3 ? 0x65 : 0x00);  // 0x65000000 bytes
  const fs::path bad = image_tmp("header_bad.exr");
  put_file(bad, bytes);
  try {
    read_image(bad.string());
    ADD_FAILURE() << "an EXR attribute larger than its file was read";
  } catch (const ptir::Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("declares"), std::string::npos) << e.what();
  }
}

// A type OpenEXR reads field by field declaring another size (what fuzz_image found
// next: a chlist read past its declared size, OpenEXR then took bytes inside it for a
// 1.98 GB string's size) is refused by name; so is a chlist that does not end where
// it declares.
TEST(ImageIo, ExrHeaderFixedTypesMustDeclareTheirSize) {
  const fs::path whole = image_tmp("header_sizes.exr");
  write_image(whole.string(), test_pattern());
  const std::string bytes = get_file(whole);
  const auto with_size = [&](const std::string& attr, int32_t size) {
    std::string b = bytes;
    const size_t at = b.find(attr);
    EXPECT_NE(at, std::string::npos) << attr;
    for (int k = 0; k < 4; ++k) b[at + attr.size() + k] = char((uint32_t(size) >> (8 * k)) & 0xff);
    return b;
  };
  const std::string box = std::string("dataWindow\0box2i\0", 17);
  const std::string chl = std::string("channels\0chlist\0", 16);
  const size_t chl_size_at = bytes.find(chl) + chl.size();
  const int32_t chl_size = int32_t(uint8_t(bytes[chl_size_at])) | int32_t(uint8_t(bytes[chl_size_at + 1])) << 8;
  const struct { std::string file; std::string says; } cases[] = {
      {with_size(box, 15), "its type has 16"}, {with_size(chl, chl_size - 1), "does not fill"}};
  for (const auto& c : cases) {
    const fs::path bad = image_tmp("header_size_bad.exr");
    put_file(bad, c.file);
    try {
      read_image(bad.string());
      ADD_FAILURE() << "an EXR attribute of the wrong size was read";
    } catch (const ptir::Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what();
    }
  }
}

// 8-bit round trip: colour goes through the sRGB curve and back, alpha is stored
// as is. Opaque linear 0.5 is byte 188; alpha 0.5 is byte 128 (OIIO stores PNG
// colour unassociated, dividing by alpha on write and multiplying on read).
TEST(ImageIo, PngKeepsAlphaLinear) {
  Image img(2, 1, {"R", "G", "B", "A"});
  const float opaque[4] = {0.5f, 0.5f, 0.5f, 1.0f}, half[4] = {0.1f, 0.1f, 0.1f, 0.5f};
  for (int c = 0; c < 4; ++c) img.at(0, 0, c) = opaque[c], img.at(1, 0, c) = half[c];
  const fs::path path = image_tmp("alpha.png");
  write_image(path.string(), img);
  const Image back = read_image(path.string());
  ASSERT_EQ(back.channels, 4);
  EXPECT_NEAR(back.at(0, 0, 0), srgb_to_linear(188.0f / 255.0f), 1e-5f);
  EXPECT_NEAR(back.at(0, 0, 3), 1.0f, 1e-6f);
  EXPECT_NEAR(back.at(1, 0, 3), 128.0f / 255.0f, 1e-5f);  // not sRGB-decoded
  EXPECT_NEAR(back.at(1, 0, 0), 0.1f, 0.004f);
  const Image data = read_image(path.string(), Encoding::Data);
  EXPECT_NEAR(data.at(0, 0, 0), 188.0f / 255.0f, 1e-5f);
}

TEST(ImageIo, WritesAtomically) {
  const fs::path dir = image_tmp("atomic");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Image img = test_pattern();
  // Success: only the target in the folder, OIIO chose the format by the target's extension.
  write_image((dir / "a.exr").string(), img);
  write_image((dir / "a.png").string(), img);
  EXPECT_TRUE(no_temps_in(dir));
  EXPECT_EQ(get_file(dir / "a.exr").substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
  EXPECT_EQ(get_file(dir / "a.png").substr(1, 3), "PNG");
  // Failure: an extension no writer knows; the old file stays and no temp is left.
  put_file(dir / "b.notaformat", "old");
  EXPECT_THROW(write_image((dir / "b.notaformat").string(), img), ptir::Error);
  EXPECT_EQ(get_file(dir / "b.notaformat"), "old");
  EXPECT_TRUE(no_temps_in(dir));
}

// A temp of a process that no longer exists is removed; ours and a live
// process's stay, and so does a file that only looks similar.
TEST(AtomicFile, RemoveStaleTemps) {
  const fs::path dir = image_tmp("stale");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path dead = dir / ".checkpoint.ptir-tmp-2147483646.bin";
  const fs::path live = dir / ".render.ptir-tmp-1.exr";  // pid 1 always exists
  const fs::path ours = io::atomic_temp_path(dir / "x.png");
  const fs::path user = dir / "checkpoint.ptir-tmp-2147483646.bin";  // no leading dot: not ours
  for (const fs::path& p : {dead, live, ours, user}) put_file(p, "x");
  EXPECT_EQ(io::remove_stale_temps(dir), 1u);
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(ours));
  EXPECT_TRUE(fs::exists(user));
}
