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

// Calls write(temp_path) to produce the file, checks it on disk to its last byte
// (fsync: a full disk or a failing device is reported here), then renames it over `path` and syncs the folder. On any failure
// (write throws, the sync or the rename fails) the temp file is removed, the
// old `path` is left as it was, and the error propagates; failures of our own
// become ptir::Error naming `path`. A `path` that exists and is not a regular
// file (a folder, /dev/null, a FIFO) is refused before anything is written.
// Callers must check their own writes (fwrite, fclose, the writer's status).
void write_atomic(const std::string& path, const std::function<void(const std::string& temp_path)>& write);

// Throws Error(path, ...) when `path` exists and is not a regular file.
void check_output_target(const std::string& path);

// Text or bytes, written atomically.
void write_text_atomic(const std::string& path, const std::string& text);
void write_bytes_atomic(const std::string& path, const void* data, size_t size);

// Removes temp files of our naming in `dir` whose writing process no longer
// exists. Returns how many were removed. Never throws.
size_t remove_stale_temps(const std::filesystem::path& dir);

}  // namespace ptir::io
