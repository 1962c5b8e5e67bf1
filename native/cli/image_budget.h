// Image size checks before anything is allocated: a side too large, a pixel
// count past the engine's limit, or a render whose memory estimate exceeds the
// budget is refused with the estimate in the message, instead of a long render
// that ends in std::bad_alloc (or an int overflow downstream).
//
// Decision: the estimate is 48 bytes per pixel (the float RGBA image, the copy
// write_image converts, and the 8-bit/RGB-only copy the CLI makes for PNGs);
// the default budget is io::memory_budget() (half the memory this process can
// have: io/memory_budget.h), raised or lowered with --max-memory GIB.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

#include "ptir/io/memory_budget.h"

namespace ptir::cli {

constexpr double kRenderBytesPerPixel = 48.0;
constexpr int64_t kMaxImageSide = io::kMaxImageSide;  // the Camera's limit (scene/camera.cpp)
constexpr int64_t kMaxImagePixels = int64_t(1) << 31;  // 2 Gpx: 32-bit pixel counts downstream

// Adds --max-memory GIB (0: half the machine's memory) to a command.
void add_max_memory_flag(CLI::App* cmd, double& gib);

// The budget in bytes: `gib` GiB when > 0, else io::memory_budget().
double memory_budget_bytes(double gib);

// Throws ptir::Error("<what>: ...") when a width x height render does not fit.
// Sides <= 0 are left to the callers' own checks.
void check_image_budget(int64_t width, int64_t height, double max_memory_gib, const std::string& what);

}  // namespace ptir::cli
