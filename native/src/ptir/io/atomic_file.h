// Atomic output: every file the engine writes goes to a temp file of our own
// naming in the target's folder, then is renamed over the target, so a reader
// (or a crash, or a kill -9) never sees a half-written file.
//
// Temp names: ".<stem>.ptir-tmp-<pid><ext>" beside the target. The extension is
// kept so format-sniffing writers (OpenImageIO) pick the right format. Temps
// left by a process that died are removed by remove_stale_temps().
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>

namespace ptir::io {

// The temp path write_atomic() uses for `target` in this process.
std::filesystem::path atomic_temp_path(const std::filesystem::path& target);

// Calls write(temp_path) to produce the file, then renames it over `path`.
// On any failure (write throws, or the rename fails) the temp file is removed
// and the error propagates; failures of our own become ptir::Error naming `path`.
void write_atomic(const std::string& path, const std::function<void(const std::string& temp_path)>& write);

// Text or bytes, written atomically.
void write_text_atomic(const std::string& path, const std::string& text);
void write_bytes_atomic(const std::string& path, const void* data, size_t size);

// Removes temp files of our naming in `dir` whose writing process no longer
// exists. Returns how many were removed. Never throws.
size_t remove_stale_temps(const std::filesystem::path& dir);

}  // namespace ptir::io
