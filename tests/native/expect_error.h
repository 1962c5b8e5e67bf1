// The native tests' check of a bad-input error: a ptir::Error whose message names the file
// and the problem (the house rule for bad input).
#pragma once

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>

#include "ptir/core/error.h"

namespace ptir::test {

// Expects fn() to throw ptir::Error whose message names the path and contains every phrase.
template <typename F>
void expect_error(F&& fn, const std::string& path, std::initializer_list<std::string> phrases) {
  try {
    fn();
    ADD_FAILURE() << "no error thrown for " << path;
  } catch (const ptir::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    for (const std::string& p : phrases) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
  }
}

}  // namespace ptir::test
