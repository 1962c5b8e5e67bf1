// Image textures, environments and photos as the scene loads them
// (scene/texture_load.cpp through io/image.cpp): the first byte picks the
// extension (.exr or .png), the rest is the file. Unlike the `image` target,
// headers declaring huge sizes are not skipped: the readers must refuse them
// against the memory budget (io/memory_budget.h) before allocating. The
// harness runs under libFuzzer's 2 GiB RSS limit, which it gives the budget
// (set_memory_limit), so a decode the budget lets through fits in it.
// Seeds: tests/fuzz/corpus/texture/ (PNG and EXR headers declaring 30000^2).
#include <OpenImageIO/imageio.h>

#include "fuzz_common.h"
#include "ptir/io/exr_header.h"
#include "ptir/io/memory_budget.h"
#include "ptir/scene/texture_load.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // One reader per extension (fuzz_image.cpp says why); the harness's memory limit for the budget.
  static const bool setup = OIIO::attribute("try_all_readers", 0) && (ptir::io::set_memory_limit(1.0 * (1 << 30)), true);
  (void)setup;
  if (size < 1) return 0;
  const std::string name = (data[0] & 1) ? "tex.exr" : "tex.png";
  const std::string path = ptir_fuzz::write_file(ptir_fuzz::scratch() / name, data + 1, size - 1);
  const auto space = (data[0] & 2) ? ptir::TextureColourSpace::Srgb : ptir::TextureColourSpace::NonColor;
  ptir_fuzz::expect_only_ptir_errors([&] { ptir::load_texture(path, space, ptir::TextureInterpolation::Linear); });
  return 0;
}
