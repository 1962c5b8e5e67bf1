#include "image_budget.h"

#include <unistd.h>

#include <cstdio>

#include "ptir/core/error.h"

namespace ptir::cli {

namespace {

constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;

double physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 8.0 * kGiB;  // unknown: assume 8 GiB
}

std::string gib_text(double bytes) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f GiB", bytes / kGiB);
  return b;
}

}  // namespace

void add_max_memory_flag(CLI::App* cmd, double& gib) {
  cmd->add_option("--max-memory", gib, "refuse images whose render needs more than this many GiB (0: half the machine's memory)")
      ->check(CLI::NonNegativeNumber);
}

double memory_budget_bytes(double gib) { return gib > 0 ? gib * kGiB : 0.5 * physical_memory_bytes(); }

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
  if (double(pixels) * kRenderBytesPerPixel > budget)
    throw Error(what, need + ", more than the budget of " + gib_text(budget) +
                          (max_memory_gib > 0 ? " (--max-memory)"
                                              : " (half of this machine's " + gib_text(physical_memory_bytes()) +
                                                    "; raise it with --max-memory GIB)"));
}

}  // namespace ptir::cli
