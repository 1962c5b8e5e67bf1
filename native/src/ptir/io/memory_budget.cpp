#include "ptir/io/memory_budget.h"

#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <fstream>

#include "ptir/core/error.h"

namespace ptir::io {

namespace {

constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
std::atomic<double> given_limit{0.0};  // set_memory_limit

double physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page > 0 ? double(pages) * double(page) : 8.0 * kGiB;  // unknown: assume 8 GiB
}

// A resource limit in bytes (0: none).
double rlimit_bytes(int resource) {
  rlimit r{};
  if (::getrlimit(resource, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return 0;
  return double(r.rlim_cur);
}

// The cgroup's memory limit in bytes (0: none or unknown): v2's memory.max, v1's memory.limit_in_bytes.
double cgroup_limit_bytes() {
  for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream in(path);
    std::string text;
    if (!(in >> text) || text == "max") continue;
    try {
      const double v = std::stod(text);
      if (v > 0 && v < 1e18) return v;  // v1 writes ~2^63 for "no limit"
    } catch (const std::exception&) {
    }
  }
  return 0;
}

}  // namespace

std::string gib_text(double bytes) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f GiB", bytes / kGiB);
  return b;
}

MemoryBudget memory_budget() {
  MemoryBudget m;
  m.limit = physical_memory_bytes();
  m.source = "this machine's memory";
  const auto lower = [&](double limit, const char* source) {
    if (limit > 0 && limit < m.limit) m.limit = limit, m.source = source;
  };
  lower(rlimit_bytes(RLIMIT_AS), "the address-space limit (ulimit -v)");
  lower(rlimit_bytes(RLIMIT_DATA), "the data-size limit (ulimit -d)");
  lower(cgroup_limit_bytes(), "the cgroup's memory limit");
  lower(given_limit.load(), "the memory limit this process was given");
  m.bytes = 0.5 * m.limit;
  return m;
}

void set_memory_limit(double bytes) { given_limit = bytes > 0 ? bytes : 0.0; }

void check_decode_size(const std::string& path, int64_t width, int64_t height, int64_t channels) {
  const std::string size = std::to_string(width) + "x" + std::to_string(height) + "x" + std::to_string(channels);
  if (width <= 0 || height <= 0 || channels <= 0) throw Error(path, "image has no pixels (its header says " + size + ")");
  if (width > kMaxImageSide || height > kMaxImageSide || channels > 64 ||
      double(width) * double(height) * double(channels) > double(kMaxImageValues))
    throw Error(path, "image declares " + size + ", past the limit of " + std::to_string(kMaxImageSide) +
                          " pixels a side and 2^31 values");
  const double pixels = double(width) * double(height);
  const double need = pixels * (kDecodeBytesPerValue * double(channels) + kDecodeBytesPerPixel);
  const MemoryBudget budget = memory_budget();
  if (need > budget.bytes)
    throw Error(path, "image declares " + size + ": decoding it needs about " + gib_text(need) +
                          ", more than the memory budget of " + gib_text(budget.bytes) + " (half of " +
                          budget.source + ", " + gib_text(budget.limit) + ")");
}

}  // namespace ptir::io
