// The collectives of a data-parallel iteration, timed on their own (bench_mpi.py
// runs it under mpirun): the gradient sum (Communicator::allreduce_sum, the
// rank-ordered reduce-scatter + allgather of native/mpi/world.cpp) of `floats`
// values, and the gather of one view's images (render_row_bands: RGBA + the five
// material-map channels) of `pixels` pixels.
//
//   bench_allreduce FLOATS PIXELS [REPS]     (prints one JSON line on rank 0)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "world.h"

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const ptir::Communicator& comm = ptir::init_world(&argc, &argv);
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_allreduce FLOATS PIXELS [REPS]\n");
    return 2;
  }
  const size_t floats = std::strtoull(argv[1], nullptr, 10), pixels = std::strtoull(argv[2], nullptr, 10);
  const int reps = argc > 3 ? std::atoi(argv[3]) : 10;
  using Clock = std::chrono::steady_clock;
  std::vector<float> g(floats, 1e-3f * float(comm.rank() + 1));
  std::vector<float> band(pixels * 9 / size_t(comm.size()), 0.5f);  // this rank's share of RGBA + 5 map channels
  std::vector<double> t_reduce, t_gather;
  for (int r = 0; r < reps + 1; ++r) {
    comm.barrier();
    auto t0 = Clock::now();
    comm.allreduce_sum(g.data(), g.size());
    auto t1 = Clock::now();
    std::vector<float> all = comm.allgather(band);
    auto t2 = Clock::now();
    if (r == 0) continue;  // warm-up
    t_reduce.push_back(std::chrono::duration<double>(t1 - t0).count());
    t_gather.push_back(std::chrono::duration<double>(t2 - t1).count());
  }
  // Every rank's result must be the same: the slowest rank is what an iteration waits for.
  double t[2] = {median(t_reduce), median(t_gather)};
  std::vector<float> tf = {float(t[0]), float(t[1])};
  std::vector<float> every = comm.allgather(tf);
  double worst_reduce = 0, worst_gather = 0;
  for (size_t q = 0; q < every.size(); q += 2) {
    worst_reduce = std::max(worst_reduce, double(every[q]));
    worst_gather = std::max(worst_gather, double(every[q + 1]));
  }
  if (comm.rank() == 0)
    std::printf("{\"ranks\": %d, \"floats\": %zu, \"pixels\": %zu, \"allreduce_s\": %.6g, \"gather_s\": %.6g}\n",
                comm.size(), floats, pixels, worst_reduce, worst_gather);
  ptir::finalize_world();
  return 0;
}
