// Numbers as text in the engine's outputs: nine significant digits ("%.9g"),
// enough to round-trip a float. json_number() rounds a value to that text so
// nlohmann::json prints floats as "0.300000012", not as the longer double
// expansion "0.30000001192092896" of the same float.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

namespace ptir {

inline std::string num_text(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

inline double json_number(double v) { return std::strtod(num_text(v).c_str(), nullptr); }

}  // namespace ptir
