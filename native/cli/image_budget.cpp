#include "image_budget.h"

#include "ptir/core/error.h"
#include "ptir/io/memory_budget.h"

namespace ptir::cli {

namespace {

constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
using io::gib_text;

}  // namespace

void add_max_memory_flag(CLI::App* cmd, double& gib) {
  cmd->add_option("--max-memory", gib, "refuse images whose render needs more than this many GiB (0: half the machine's memory)")
      ->check(CLI::NonNegativeNumber);
}

double memory_budget_bytes(double gib) { return gib > 0 ? gib * kGiB : io::memory_budget().bytes; }

void check_image_budget(int64_t width, int64_t height, double max_memory_gib, const std::string& what) {
  if (width <= 0 || height <= 0) return;
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  const int64_t pixels = width * height;  // both <= 2^31: no overflow
  const std::string need = "a " + size + " image needs about " + gib_text(double(pixels) * kRenderBytesPerPixel) +
                           " of memory to render (" + std::to_string(int(kRenderBytesPerPixel)) + " bytes per pixel)";
  if (width > kMaxImageSide || height > kMaxImageSide)
    throw Error(what, need + ", and the largest side is " + std::to_string(kMaxImageSide) + " pixels");
  if (pixels > kMaxImagePixels)
    throw Error(what, need + ", and the engine handles at most " + std::to_string(kMaxImagePixels) + " pixels");
  const double budget = memory_budget_bytes(max_memory_gib);
  const io::MemoryBudget machine = io::memory_budget();
  if (double(pixels) * kRenderBytesPerPixel > budget)
    throw Error(what, need + ", more than the budget of " + gib_text(budget) +
                          (max_memory_gib > 0 ? " (--max-memory)"
                                              : " (half of " + machine.source + ", " + gib_text(machine.limit) +
                                                    "; raise it with --max-memory GIB)"));
}

}  // namespace ptir::cli
