// Reading input files with bounds: only regular files (a FIFO, /dev/zero or a
// folder is refused at once, before anything blocks or grows), and a size cap
// checked before a byte is read. Every message names the file.
//
// Decision: the caps are per kind of file (a scene or dataset JSON is text a
// person or an exporter writes: 256 MiB is far past any real one; bulk files of
// the engine protocol are bounded by what they must hold, checked by the caller).
#pragma once

#include <cstdint>
#include <string>

namespace ptir::io {

constexpr uint64_t kMaxTextInputBytes = uint64_t(256) << 20;  // JSON / text inputs

// Throws Error(path, ...) unless `path` names an existing regular file (links
// followed); returns its size in bytes. `what` says what the file is for
// ("scene file", "COLMAP images.txt").
uint64_t check_regular_file(const std::string& path, const std::string& what);

// The whole file, after check_regular_file and a size check against max_bytes.
// Opened without blocking (a FIFO swapped in after the check does not hang).
std::string read_input_file(const std::string& path, const std::string& what,
                            uint64_t max_bytes = kMaxTextInputBytes);

}  // namespace ptir::io
