// A one-line progress bar on stderr, redrawn at most a few times a second.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace ptir::cli {

class ProgressBar {
 public:
  ProgressBar(std::string label, bool quiet) : label_(std::move(label)), quiet_(quiet), start_(clock::now()) {}

  void update(float fraction) {
    if (quiet_) return;
    auto now = clock::now();
    if (fraction < 1.0f && now - last_ < std::chrono::milliseconds(200)) return;
    last_ = now;
    double elapsed = std::chrono::duration<double>(now - start_).count();
    double eta = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    int filled = int(fraction * 30.0f + 0.5f);
    std::fprintf(stderr, "\r%s [%-30s] %5.1f%%  %.1fs  ETA %.1fs", label_.c_str(), std::string(size_t(filled), '#').c_str(),
                 100.0 * fraction, elapsed, eta);
    std::fflush(stderr);
  }
  void finish() {
    if (quiet_) return;
    update(1.0f);
    std::fprintf(stderr, "\n");
  }

 private:
  using clock = std::chrono::steady_clock;
  std::string label_;
  bool quiet_;
  clock::time_point start_, last_{};
};

}  // namespace ptir::cli
