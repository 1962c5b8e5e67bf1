// The collectives data-parallel runs need (issue 15: `mpirun -np N ptir ...`),
// behind one small interface so that nothing above this file knows about MPI.
//
// This base class is the single process: rank 0 of 1, every collective the
// identity. The MPI implementation (native/mpi/mpi_communicator.cpp) is compiled
// into the `ptir` binary only when CMake finds MPI (PTIR_WITH_MPI); the engine
// libraries and the Python module never link MPI.
//
// Every rank must make the same calls in the same order (they are collectives).
//
// Reduction order (allreduce_sum): element i of the result is
//   ((g_0[i] + g_1[i]) + g_2[i]) + ... + g_{N-1}[i]
// -- the ranks' values summed left to right in rank order, in float -- and every
// rank receives the very same bits (one rank sums each element, then it is
// broadcast). So a run is deterministic for a given N; across different N the
// sums differ only by that re-association (float rounding).
#pragma once

#include <cstddef>
#include <vector>

namespace ptir {

class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const { return 0; }
  virtual int size() const { return 1; }
  virtual int local_size() const { return 1; }  // ranks on this machine (this one included)
  // In place: data[0..n) becomes the sum over ranks, in the order documented above.
  virtual void allreduce_sum(float* data, size_t n) const {}
  virtual void allreduce_sum(double* data, size_t n) const {}  // statistics, counts
  // Every rank's `mine`, concatenated in rank order; counts (optional) receives
  // each rank's element count.
  virtual std::vector<float> allgather(const std::vector<float>& mine, std::vector<size_t>* counts = nullptr) const {
    if (counts) *counts = {mine.size()};
    return mine;
  }
  // bytes of `data` from `root` to every rank.
  virtual void broadcast(void* data, size_t bytes, int root = 0) const {}
  virtual void barrier() const {}
  // Ends every rank of the job with `code` (after a rank failed alone). The single
  // process returns: its caller exits by itself.
  virtual void abort(int code) const {}
};

// The single-process communicator (identity collectives).
inline const Communicator& single_process() {
  static const Communicator c;
  return c;
}

}  // namespace ptir
