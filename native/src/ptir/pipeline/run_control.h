// What the long-running commands (optimize, fit) share: Ctrl-C handling and
// the duration text of their progress lines.
#pragma once

#include <atomic>
#include <string>

namespace ptir::pipeline {

// Set by the first Ctrl-C after install_sigint(); a second one ends the process at once.
extern std::atomic<bool> g_interrupted;

// Clears g_interrupted and installs the handler; returns the previous handler
// for restore_sigint.
using SignalHandler = void (*)(int);
SignalHandler install_sigint();
void restore_sigint(SignalHandler previous);

// f()'s result, with the Ctrl-C handler set back to `previous` afterwards (also when f throws).
template <class F>
auto with_sigint_restored(SignalHandler previous, F&& f) -> decltype(f()) {
  try {
    auto r = f();
    restore_sigint(previous);
    return r;
  } catch (...) {
    restore_sigint(previous);
    throw;
  }
}

// "12.3s", "4m05s", "1h02m"; "?" for a negative or non-finite value.
std::string duration_text(double seconds);

}  // namespace ptir::pipeline
