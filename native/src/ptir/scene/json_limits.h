// JSON text -> nlohmann::json with bounds, for every JSON the engine reads
// (scene files, datasets' transforms.json, engine-protocol request lines):
// nesting deeper than kMaxJsonDepth is refused before the parser runs (deep
// nesting made the recursive walks after parsing overflow the stack), and every
// parser failure (syntax, invalid UTF-8, a number that overflows a double such
// as 1e400) becomes one ptir::Error naming the input.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace ptir {

constexpr int kMaxJsonDepth = 128;  // the deepest real scene file nests 6 levels

// Throws Error(name, "invalid JSON: ...") or Error(name, "JSON nested deeper than ...").
nlohmann::json parse_json_bounded(const std::string& text, const std::string& name, int max_depth = kMaxJsonDepth);

// A file read with io::read_input_file (regular files only, size cap) and parsed as above.
nlohmann::json load_json_file(const std::string& path, const std::string& what);

// Text of a JSON value that never throws: invalid UTF-8 in strings is replaced
// (U+FFFD) instead of failing the dump (replies that echo bad input).
std::string dump_json_safe(const nlohmann::json& j);

}  // namespace ptir
