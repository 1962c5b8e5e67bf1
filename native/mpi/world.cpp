// The only file that calls MPI (world.h). Reduction order: core/communicator.h.
#include "world.h"

#include <cstdio>
#include <cstdlib>
#include <memory>

#ifdef PTIR_WITH_MPI
#include <mpi.h>

#include <algorithm>
#include <climits>
#include <string>

#include "ptir/core/error.h"
#endif

namespace ptir {

namespace {
const Communicator* g_world = nullptr;
}

const Communicator& world() { return g_world ? *g_world : single_process(); }

// A Slurm step of several tasks that MPI does not join (srun without --mpi=pmix, or
// a build without MPI) runs N independent copies: say so once, from task 0.
static void warn_unjoined_slurm_step() {
  const char* tasks = std::getenv("SLURM_STEP_NUM_TASKS");
  const char* task = std::getenv("SLURM_PROCID");
  if (tasks && std::atoi(tasks) > 1 && task && std::atoi(task) == 0)
    std::fprintf(stderr,
                 "ptir: warning: this Slurm step has %s tasks but they are not one MPI job (%s): each runs alone\n",
                 tasks, world_library()[0] == 'n' ? "this ptir was built without MPI" : "use srun --mpi=pmix");
}

#ifndef PTIR_WITH_MPI

const Communicator& init_world(int*, char***) {
  warn_unjoined_slurm_step();
  return world();
}
void finalize_world() {}
const char* world_library() { return "none"; }

#else

namespace {

void check(int rc, const char* what) {
  if (rc == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(rc, text, &len);
  throw Error(std::string("MPI ") + what + " failed: " + std::string(text, size_t(len)));
}

int int_count(size_t n) {
  if (n > size_t(INT_MAX)) throw Error("MPI: a message of " + std::to_string(n) + " elements is too large");
  return int(n);
}

class MpiCommunicator final : public Communicator {
 public:
  MpiCommunicator() {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    // Errors come back as codes (thrown as ptir::Error, then the job is aborted)
    // rather than killing the process without a word.
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm node;
    check(MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node), "Comm_split_type");
    MPI_Comm_size(node, &local_size_);
    MPI_Comm_free(&node);
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  int local_size() const override { return local_size_; }

  // Reduce-scatter then allgather, each element summed by one rank in rank order
  // (core/communicator.h); in chunks of at most kChunk elements (the sums are
  // element-wise, so chunking changes nothing).
  void allreduce_sum(float* data, size_t n) const override { reduce(data, n, MPI_FLOAT); }
  void allreduce_sum(double* data, size_t n) const override { reduce(data, n, MPI_DOUBLE); }

  std::vector<float> allgather(const std::vector<float>& mine, std::vector<size_t>* counts) const override {
    const unsigned long long my_count = mine.size();
    std::vector<unsigned long long> all_counts(size_t(size_), 0);
    check(MPI_Allgather(&my_count, 1, MPI_UNSIGNED_LONG_LONG, all_counts.data(), 1, MPI_UNSIGNED_LONG_LONG,
                        MPI_COMM_WORLD),
          "Allgather");
    std::vector<int> c(static_cast<size_t>(size_)), displ(static_cast<size_t>(size_));
    size_t total = 0;
    for (int q = 0; q < size_; ++q) {
      c[size_t(q)] = int_count(all_counts[size_t(q)]);
      displ[size_t(q)] = int_count(total);
      total += all_counts[size_t(q)];
    }
    int_count(total);
    std::vector<float> out(total);
    check(MPI_Allgatherv(mine.data(), int_count(mine.size()), MPI_FLOAT, out.data(), c.data(), displ.data(), MPI_FLOAT,
                         MPI_COMM_WORLD),
          "Allgatherv");
    if (counts) counts->assign(all_counts.begin(), all_counts.end());
    return out;
  }

  void broadcast(void* data, size_t bytes, int root) const override {
    check(MPI_Bcast(data, int_count(bytes), MPI_BYTE, root, MPI_COMM_WORLD), "Bcast");
  }
  void barrier() const override { check(MPI_Barrier(MPI_COMM_WORLD), "Barrier"); }
  void abort(int code) const override { MPI_Abort(MPI_COMM_WORLD, code); }

 private:
  template <class T>
  void reduce(T* data, size_t n, MPI_Datatype type) const {
    if (size_ == 1) return;
    constexpr size_t kChunk = size_t(1) << 24;
    for (size_t at = 0; at < n; at += kChunk) reduce_chunk(data + at, std::min(kChunk, n - at), type);
  }

  // Rank q owns elements [n q / N, n (q + 1) / N): it receives every rank's copy of
  // them (Alltoallv), sums them in rank order, and the sums are gathered by all.
  template <class T>
  void reduce_chunk(T* data, size_t n, MPI_Datatype type) const {
    std::vector<int> count(static_cast<size_t>(size_)), displ(static_cast<size_t>(size_));
    for (int q = 0; q < size_; ++q) {
      const size_t b = n * size_t(q) / size_t(size_), e = n * size_t(q + 1) / size_t(size_);
      count[size_t(q)] = int(e - b);
      displ[size_t(q)] = int(b);
    }
    const int mine = count[size_t(rank_)];
    std::vector<int> rcount(static_cast<size_t>(size_), mine), rdispl(static_cast<size_t>(size_));
    for (int q = 0; q < size_; ++q) rdispl[size_t(q)] = q * mine;
    std::vector<T> parts(size_t(mine) * size_t(size_));
    check(MPI_Alltoallv(data, count.data(), displ.data(), type, parts.data(), rcount.data(), rdispl.data(), type,
                        MPI_COMM_WORLD),
          "Alltoallv");
    std::vector<T> sum(parts.begin(), parts.begin() + mine);
    for (int q = 1; q < size_; ++q) {
      const T* p = parts.data() + size_t(q) * size_t(mine);
      for (int i = 0; i < mine; ++i) sum[size_t(i)] += p[i];
    }
    check(MPI_Allgatherv(sum.data(), mine, type, data, count.data(), displ.data(), type, MPI_COMM_WORLD),
          "Allgatherv");
  }

  int rank_ = 0, size_ = 1, local_size_ = 1;
};

// Started by an MPI launcher? (Open MPI's mpirun, PMIx launchers such as srun
// --mpi=pmix, and PMI-1/2 launchers.)
bool launched_by_mpi() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
    if (std::getenv(v)) return true;
  return false;
}

std::unique_ptr<MpiCommunicator> g_mpi;

}  // namespace

const Communicator& init_world(int* argc, char*** argv) {
  if (g_world) return world();
  if (!launched_by_mpi()) {
    warn_unjoined_slurm_step();
    return world();
  }
  int provided = 0;
  check(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided), "Init");
  g_mpi = std::make_unique<MpiCommunicator>();
  g_world = g_mpi.get();
  return *g_world;
}

void finalize_world() {
  if (!g_mpi) return;
  g_world = nullptr;
  g_mpi.reset();
  MPI_Finalize();
}

const char* world_library() {
  static std::string text = [] {
    char v[MPI_MAX_LIBRARY_VERSION_STRING];
    int len = 0;
    MPI_Get_library_version(v, &len);
    std::string s(v, size_t(len));
    return s.substr(0, s.find_first_of(",\n"));
  }();
  return text.c_str();
}

#endif

}  // namespace ptir
