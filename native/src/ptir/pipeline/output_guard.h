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

#include <memory>
#include <string>
#include <vector>

#include "ptir/io/output_lock.h"

namespace ptir::pipeline {

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

// Throws ptir::Error naming the output and the input it would overwrite (and
// --force) unless `force`.
void guard_outputs(const Inputs& inputs, const Outputs& outputs, bool force);

// A command's own result folder (optimize and fit --out): new, empty, or a result
// of ours (output_guard.cpp: is_our_result), never a folder of someone's photos or
// poses -- transforms*.json, images/, sparse/, a 3DGS output's cameras.json and
// cfg_args, or photos at its top -- which the result's fixed names (gaussians.ply,
// checkpoint.bin) would land among, even when it is not passed as --dataset.
// Throws ptir::Error naming the folder and what it holds, unless `force`.
void guard_result_folder(const std::string& dir, bool force);

// One writer per output folder (io/output_lock.h): every command that writes a
// folder (optimize, fit, eval, relight) holds its lock for as long as it runs.
// Creates `dir` if missing; throws ptir::Error naming the folder and the process
// that holds it. The lock goes with the returned object (and with the process).
[[nodiscard]] std::unique_ptr<io::OutputLock> lock_output_folder(const std::string& dir, const std::string& command);

// Removes temps of our naming (io/atomic_file.h) whose process is gone from
// each folder (and, with `with_subfolders`, its immediate subfolders), so a run
// killed mid-write leaves nothing behind for good. Reports the count on stderr
// unless quiet. Never throws.
void remove_stale_outputs(const std::vector<std::string>& folders, bool quiet, bool with_subfolders = false);

}  // namespace ptir::pipeline
