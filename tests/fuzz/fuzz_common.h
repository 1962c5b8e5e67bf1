// Shared pieces of the libFuzzer harnesses (tests/fuzz/README.md): a private
// scratch folder, the fuzz input as a file in it, and the rule of every
// harness: a reader may refuse an input only with ptir::Error (a message that
// names the file); any other exception, a crash, a leak or a hang is a finding.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include "ptir/core/error.h"

namespace ptir_fuzz {

namespace fs = std::filesystem;

// A folder of this process's own under /dev/shm (or /tmp), made once.
inline const fs::path& scratch() {
  static const fs::path dir = [] {
    fs::path base = fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
    fs::path d = base / ("ptir_fuzz_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

inline std::string write_file(const fs::path& path, const uint8_t* data, size_t size) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  return path.string();
}

inline std::string write_file(const fs::path& path, const std::string& text) {
  return write_file(path, reinterpret_cast<const uint8_t*>(text.data()), text.size());
}

// Runs f; ptir::Error is an accepted refusal, anything else aborts (a finding).
template <class F>
void expect_only_ptir_errors(F&& f) {
  try {
    f();
  } catch (const ptir::Error&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz finding: an exception other than ptir::Error escaped: %s\n", e.what());
    std::abort();
  }
}

}  // namespace ptir_fuzz
