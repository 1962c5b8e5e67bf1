// Run under `mpirun -np N`: the gradients of a data-parallel iteration against
// one process, on every rank (tests/python/test_mpi.py runs it).
//
//   ptir_mpi_gradient_check DATASET GAUSSIANS [ITERATIONS [SPP [VIEWS_PER_ITER [CROP]]]]
//
// Each rank builds the same optimiser twice: one alone (single_process) and one
// sharing the job (world()). For iterations 0..ITERATIONS-1 both evaluate the
// objective and its gradients at the initial parameters (Optimizer::evaluate), and
// rank 0 prints one JSON line per iteration: the losses of both (they must be the
// same bits: the images are gathered whole) and, over every gradient entry, the
// largest |difference|, the largest |entry| and the count of entries that differ
// -- what float re-association may change (optim/data_parallel.h).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>

#include "ptir/optim/optimizer.h"
#include "ptir/optim/optimizer_setup.h"
#include "ptir/scene/gaussian_ply.h"
#include "world.h"

namespace {

using namespace ptir;

std::unique_ptr<Optimizer> make(const std::string& dataset_dir, const std::string& ply, int spp, int views, int crop,
                                std::shared_ptr<const Dataset>& data) {
  OptimizeOptions o;
  o.spp = spp;
  o.views_per_iter = views;
  o.crop = crop;
  o.env_width = 16;
  o.env_height = 8;
  o.seed = 7;
  OptimizerSettings s = optimizer_settings(o, cli_option_name);
  if (!data) data = load_dataset(dataset_dir, DatasetOptions{});
  Scene scene = prepare_optimizer_scene("", std::make_shared<GaussianField>(load_gaussians(ply)), s, cli_option_name);
  return std::make_unique<Optimizer>(std::move(scene), data, s);
}

// Visits the matching entries of two gradient sets.
template <class F>
void each_pair(const SceneGradients& a, const SceneGradients& b, F&& f) {
  for (size_t i = 0; i < a.gaussian_albedo.size(); ++i) {
    f(a.gaussian_albedo[i].x, b.gaussian_albedo[i].x);
    f(a.gaussian_albedo[i].y, b.gaussian_albedo[i].y);
    f(a.gaussian_albedo[i].z, b.gaussian_albedo[i].z);
  }
  for (size_t i = 0; i < a.gaussian_roughness.size(); ++i) f(a.gaussian_roughness[i], b.gaussian_roughness[i]);
  for (size_t i = 0; i < a.gaussian_metallic.size(); ++i) f(a.gaussian_metallic[i], b.gaussian_metallic[i]);
  for (size_t i = 0; i < a.environment.size(); ++i) f(a.environment[i], b.environment[i]);
}

}  // namespace

int main(int argc, char** argv) {
  const Communicator& comm = init_world(&argc, &argv);
  try {
    if (argc < 3) throw Error("usage: ptir_mpi_gradient_check DATASET GAUSSIANS [ITERATIONS [SPP [VIEWS [CROP]]]]");
    const int iterations = argc > 3 ? std::atoi(argv[3]) : 2;
    const int spp = argc > 4 ? std::atoi(argv[4]) : 4;
    const int views = argc > 5 ? std::atoi(argv[5]) : 1;
    const int crop = argc > 6 ? std::atoi(argv[6]) : 0;
    std::shared_ptr<const Dataset> data;
    auto alone = make(argv[1], argv[2], spp, views, crop, data);
    auto shared = make(argv[1], argv[2], spp, views, crop, data);
    shared->set_communicator(comm);
    for (int it = 0; it < iterations; ++it) {
      const IterationLog la = alone->evaluate(it, true);
      const IterationLog lb = shared->evaluate(it, true);
      double max_diff = 0, max_abs = 0, sum_abs = 0;
      size_t differ = 0, entries = 0;
      each_pair(alone->gradients(), shared->gradients(), [&](float x, float y) {
        max_diff = std::max(max_diff, double(std::fabs(x - y)));
        max_abs = std::max(max_abs, double(std::fabs(x)));
        sum_abs += std::fabs(x);
        differ += (x != y);
        ++entries;
      });
      if (comm.rank() == 0)
        std::printf("{\"ranks\": %d, \"iteration\": %d, \"loss_alone\": %.17g, \"loss_ranks\": %.17g, \"max_diff\": %.9g, "
                    "\"max_abs\": %.9g, \"sum_abs\": %.9g, \"differ\": %zu, \"entries\": %zu}\n",
                    comm.size(), it, la.loss, lb.loss, max_diff, max_abs, sum_abs, differ, entries);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ptir_mpi_gradient_check: error (rank %d): %s\n", comm.rank(), e.what());
    if (comm.size() > 1) comm.abort(1);
    return 1;
  }
  finalize_world();
  return 0;
}
