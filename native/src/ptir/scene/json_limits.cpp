#include "ptir/scene/json_limits.h"

#include "ptir/core/error.h"
#include "ptir/io/input_file.h"

namespace ptir {

namespace {

// The deepest nesting of [ and { outside strings (stops counting past `limit`),
// and the line where it first went past it.
void check_depth(const std::string& text, const std::string& name, int limit) {
  int depth = 0;
  size_t line = 1;
  bool in_string = false, escaped = false;
  for (char c : text) {
    if (c == '\n') ++line;
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '[' || c == '{') {
      if (++depth > limit)
        throw Error(name, "invalid JSON: nested deeper than " + std::to_string(limit) + " levels (line " +
                              std::to_string(line) + ")");
    } else if ((c == ']' || c == '}') && depth > 0) --depth;
  }
}

}  // namespace

nlohmann::json parse_json_bounded(const std::string& text, const std::string& name, int max_depth) {
  check_depth(text, name, max_depth);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    // e.what() is "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
    const std::string what = e.what();
    const auto pos = what.find("] ");
    throw Error(name, "invalid JSON: " + (pos == std::string::npos ? what : what.substr(pos + 2)));
  }
}

nlohmann::json load_json_file(const std::string& path, const std::string& what) {
  return parse_json_bounded(io::read_input_file(path, what), path);
}

std::string dump_json_safe(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace ptir
