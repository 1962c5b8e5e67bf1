// Progress reporting and cancellation for long renders.
#pragma once

#include <atomic>
#include <functional>

namespace ptir {

struct RenderControl {
  std::function<void(float)> progress;        // fraction done; called under a lock from worker threads
  const std::atomic<bool>* cancel = nullptr;  // set to stop early (the render throws ptir::Cancelled)
};

}  // namespace ptir
