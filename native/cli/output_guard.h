// What every command does before it writes: refuse outputs that would land on
// its inputs, and clear temps that a killed run left in its output folders.
//
// Decision (the rule of "over the inputs"), unless --force:
//  - an output file may not be an input file (same file, however spelled);
//  - an output folder may not be an input folder (a dataset, a result, a prior
//    folder) nor directly hold an input file: the commands write fixed names
//    (gaussians.ply, env.exr, <camera>.exr ...) at its top, which would replace
//    the input in place. Folders further up (e.g. --out . above the dataset) are
//    fine: nothing is written into the inputs' own folders;
//  - nothing is written among a dataset's files: no output file in the dataset's
//    folder or any existing folder under it (`cameras -o DATASET/transforms.json`,
//    `-o DATASET/sparse/0/cameras.txt`), no output folder that is one of them
//    (`optimize --out DATASET/images`). A new folder directly in the dataset
//    (`--out DATASET/result`) is fine, and so is a result folder of ours there
//    (it holds a checkpoint.bin or log.csv, or gaussians.ply beside env.exr: a
//    result eval reads, e.g. the dataset maker's oracle/).
// Inputs given as a scene file also bring the files the scene names (any string
// in the JSON that names an existing file beside the scene or at an absolute
// path), so `render scene.json -o env.exr` cannot replace the scene's map; for
// those only output files count, not output folders (a scene's folder usually
// holds its assets, and writing beside them is fine).
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace ptir::cli {

struct Inputs {
  std::vector<std::string> files;     // files read (missing ones are skipped)
  std::vector<std::string> folders;   // folders read (datasets, results, priors)
  std::vector<std::string> scenes;    // scene files: they and the files they name
  std::vector<std::string> datasets;  // folders nothing is written into, at any depth (photos, cameras)
};

struct Outputs {
  std::vector<std::string> files;    // files written
  std::vector<std::string> folders;  // folders written into
};

// Adds --force (write even over the inputs) to a command.
void add_force_flag(CLI::App* cmd, bool& force);

// Throws ptir::Error naming the output and the input it would overwrite (and
// --force) unless `force`.
void guard_outputs(const Inputs& inputs, const Outputs& outputs, bool force);

// Removes temps of our naming (io/atomic_file.h) whose process is gone from
// each folder (and, with `with_subfolders`, its immediate subfolders), so a run
// killed mid-write leaves nothing behind for good. Reports the count on stderr
// unless quiet. Never throws.
void remove_stale_outputs(const std::vector<std::string>& folders, bool quiet, bool with_subfolders = false);

}  // namespace ptir::cli
