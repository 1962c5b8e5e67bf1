#include "ptir/render/tile_reduce.h"

#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <mutex>
#include <vector>

#include "ptir/core/error.h"

namespace ptir {

namespace {

// Reusable tile buffers (at most one per token), so their allocations persist.
class TilePool {
 public:
  TilePool(const SceneGradients& like, const SceneEnvironment& env) : like_(like), env_(env) {}
  GradientTile* acquire() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) {
      all_.push_back(std::make_unique<GradientTile>(like_, env_));
      return all_.back().get();
    }
    GradientTile* t = free_.back();
    free_.pop_back();
    return t;
  }
  void release(GradientTile* t) {
    t->clear();
    std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(t);
  }
  size_t size() const { return all_.size(); }

 private:
  const SceneGradients& like_;
  const SceneEnvironment& env_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<GradientTile>> all_;
  std::vector<GradientTile*> free_;
};

}  // namespace

int gradient_tile_side(int width, int height) {
  int side = 16;
  auto tiles = [&](int s) { return size_t((width + s - 1) / s) * size_t((height + s - 1) / s); };
  while (side > 4 && tiles(side) < 64) side /= 2;
  return side;
}

void reduce_gradient_tiles(int width, int height, const SceneEnvironment& env, SceneGradients& grads,
                           const RenderControl& control, const std::function<void(const PixelTile&, GradientTile&)>& work,
                           TileReduceStats* stats) {
  const int side = gradient_tile_side(width, height);
  const int tiles_x = (width + side - 1) / side, tiles_y = (height + side - 1) / side;
  const size_t tiles = size_t(tiles_x) * size_t(tiles_y);
  if (tiles == 0) return;
  const size_t tokens = size_t(kTokensPerThread) * size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
  TilePool pool(grads, env);
  auto cancelled = [&] { return control.cancel && control.cancel->load(); };
  size_t next = 0, done = 0, entries = 0, peak = 0;
  double stage = 0.0;

  tbb::parallel_pipeline(
      tokens,
      tbb::make_filter<void, size_t>(tbb::filter_mode::serial_in_order,
                                     [&](tbb::flow_control& fc) -> size_t {
                                       if (next == tiles || cancelled()) {
                                         fc.stop();
                                         return 0;
                                       }
                                       return next++;
                                     }) &
          tbb::make_filter<size_t, GradientTile*>(tbb::filter_mode::parallel,
                                                  [&](size_t t) {
                                                    GradientTile* g = pool.acquire();
                                                    const int tx = int(t % size_t(tiles_x)), ty = int(t / size_t(tiles_x));
                                                    PixelTile tile{tx * side, ty * side, std::min(width, (tx + 1) * side),
                                                                   std::min(height, (ty + 1) * side)};
                                                    if (!cancelled()) work(tile, *g);
                                                    g->finish();
                                                    return g;
                                                  }) &
          tbb::make_filter<GradientTile*, void>(tbb::filter_mode::serial_in_order, [&](GradientTile* g) {
            const auto t0 = std::chrono::steady_clock::now();
            g->add_to(grads);
            stage += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            entries += g->gaussian_entries();
            peak = std::max(peak, g->bytes());
            pool.release(g);
            ++done;
            if (control.progress) control.progress(float(done) / float(tiles));
          }));
  if (cancelled()) throw Cancelled();
  if (stats) {
    stats->tiles += tiles;
    stats->entries += entries;
    stats->peak_tile_bytes = std::max(stats->peak_tile_bytes, peak);
    stats->buffers = std::max(stats->buffers, pool.size());
    stats->stage_seconds += stage;
  }
}

}  // namespace ptir
