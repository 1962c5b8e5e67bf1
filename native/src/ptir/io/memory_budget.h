// What this process may allocate, and the check every image reader makes
// against a file's header before it allocates the pixels (photos, textures,
// environments, render targets): a 138-byte PNG may declare 30000x30000.
//
// Decision: the budget is half of the memory this process can have: the
// machine's physical memory, or less under an address-space or data limit
// (ulimit -v / -d) or a cgroup's memory.max (a container, systemd-run). A
// decode is counted as 4 bytes per value (the float pixels) plus 16 per pixel
// (the one float RGB(A) copy every reader makes: texels, a training image's
// colour and alpha, an environment's sampling table), so the refusal comes
// before a std::bad_alloc that names no file.
#pragma once

#include <cstdint>
#include <string>

namespace ptir::io {

constexpr int64_t kMaxImageSide = 65536;                    // the Camera's limit (scene/camera.cpp)
constexpr int64_t kMaxImageValues = int64_t(1) << 31;       // 32-bit value counts downstream
constexpr double kDecodeBytesPerValue = 4.0, kDecodeBytesPerPixel = 16.0;

struct MemoryBudget {
  double bytes = 0;     // half of `limit`
  double limit = 0;     // the memory this process can have
  std::string source;   // what sets `limit`: "this machine's memory", "the address-space limit (ulimit -v)", ...
};

// Half of the smallest of: physical memory, RLIMIT_AS, RLIMIT_DATA, the cgroup's
// memory limit, and the limit set_memory_limit gave.
MemoryBudget memory_budget();

// A limit the caller knows and the system does not (the fuzz harnesses run under
// libFuzzer's -rss_limit_mb, which no rlimit shows); 0 removes it.
void set_memory_limit(double bytes);

// "12.3 GiB".
std::string gib_text(double bytes);

// Throws Error(path, "image declares WxHxC, ...") when the header's size is past
// the engine's limits (kMaxImageSide a side, kMaxImageValues values) or its
// decode would need more than memory_budget().
void check_decode_size(const std::string& path, int64_t width, int64_t height, int64_t channels);

}  // namespace ptir::io
