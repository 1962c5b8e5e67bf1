// Optimiser checkpoints: everything needed to continue a run bit-exactly.
//
// The randomness of an iteration is keyed on (seed, iteration) (views, crops,
// path samples), so the state is only: the completed iteration count, the raw
// parameters with their Adam moments and step counts, the (fixed) shading normals
// the run oriented, and the log so far. A fingerprint of the inputs and
// settings that affect the result (as key/value text) is stored and compared on
// resume, so a checkpoint is never applied to a different problem.
//
// File: little-endian binary, "PTIRCKPT" + version, ..., FNV-1a 64 checksum of
// everything before it (truncation and corruption are detected). Written
// atomically (io/atomic_file.h).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "ptir/math/vec.h"
#include "ptir/optim/parameters.h"

namespace ptir {

// One row of log.csv.
struct IterationLog {
  int iteration = 0;  // 1-based: the iteration just completed
  double loss = 0, image = 0, tv = 0, prior = 0;  // total and terms (weighted)
  double prior_weight = 0;
  double seconds = 0;        // wall time of the iteration
  double primal_s = 0, backward_s = 0, regulariser_s = 0, update_s = 0;  // its parts
  // Process CPU time (all threads) of the iteration and of its two path-tracing
  // passes: a measure of the work that a busy, shared machine does not inflate.
  double cpu_s = 0, primal_cpu_s = 0, backward_cpu_s = 0;
  std::string views;         // names of the views used, '+'-separated
  int level = 1;             // the resolution pyramid's reduction factor of its views (not in checkpoints)
};

using Fingerprint = std::vector<std::pair<std::string, std::string>>;

struct CheckpointGroup {
  ParamKind kind;
  float lr = 0;
  uint64_t adam_t = 0;
  std::vector<float> raw, m, v;
};

struct Checkpoint {
  uint64_t iteration = 0;
  Fingerprint fingerprint;
  std::vector<CheckpointGroup> groups;
  std::vector<Vec3> normals;
  std::vector<IterationLog> log;
  // The iterate average of --average-from (measured, lost and removed after
  // aa311c4; docs/inversion.md): iterates summed, the iteration after which it
  // began, and per group the sum. Written empty; a checkpoint that holds an
  // average is refused. Version 1 files have none.
  uint64_t averaged = 0;
  int64_t average_begin = 0;
  std::vector<std::vector<double>> average_sum;
};

void write_checkpoint(const std::string& path, const Checkpoint& c);
Checkpoint read_checkpoint(const std::string& path);

// Throws Error(path, ...) listing every key whose value differs (or is missing).
void check_fingerprint(const std::string& path, const Fingerprint& stored, const Fingerprint& current);

// The last commit whose ptir resumes checkpoints of the options removed since
// (retire_fingerprint_entries, optimizer_fingerprint.cpp; docs/inversion.md).
inline constexpr const char* kLastCommitWithRetiredOptions = "aa311c4";
// Drops from `stored` the entries of removed options at the values their
// defaults wrote; throws Error naming the option (and that commit) otherwise.
void retire_fingerprint_entries(const std::string& path, Fingerprint& stored);

}  // namespace ptir
