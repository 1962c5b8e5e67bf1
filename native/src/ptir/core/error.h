// The one exception type the engine throws for bad input or failed I/O.
// Every message names the file (when there is one) and the problem, so the CLI,
// the Python module and the add-on can show it to the user as is.
#pragma once

#include <stdexcept>
#include <string>

namespace ptir {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
  // "<path>: <problem>"
  Error(const std::string& path, const std::string& problem) : std::runtime_error(path + ": " + problem) {}
};

// Raised by long operations when the caller's cancel flag is set.
class Cancelled : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

}  // namespace ptir
