// Atomic output of a whole folder: a command that writes many files which only
// make sense together (`ptir eval`'s renders beside their metrics.json, the
// PLY-only plan's views and targets) writes them into a staging folder and
// replaces the real one with it at the end, in one step. A failure before that
// (a full disk, an error, a kill) leaves the previous folder as it was.
#pragma once

#include <string>

namespace ptir::io {

// Replaces the folder `target` (or creates it, when missing) by the finished folder
// `staged`, which must be on the same file system (beside it): renameat2's
// RENAME_EXCHANGE swaps them atomically, then the old contents (now at `staged`)
// are removed. Where the file system cannot exchange, the old folder is renamed
// aside first (a crash between the two renames leaves it at `staged`.old).
// Throws ptir::Error naming `target` when a rename fails.
void replace_folder(const std::string& staged, const std::string& target);

}  // namespace ptir::io
