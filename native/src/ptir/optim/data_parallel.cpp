#include "ptir/optim/data_parallel.h"

#include <algorithm>

#include "ptir/optim/optimizer.h"
#include "ptir/render/aov_backward.h"
#include "ptir/render/render_path.h"
#include "ptir/render/row_bands.h"

namespace ptir {

Image render_path_ranks(const Communicator& comm, const PathTracer& tracer, const Camera& camera,
                        const IntegratorSettings& settings, const RenderControl& control,
                        std::vector<ReplayCache>* cache) {
  if (cache) cache->resize(rank_row_bands(camera.height, comm).size());
  return render_row_bands(comm, camera, [&](const Camera& band, size_t b) {
    return render_path(tracer, band, settings, control, nullptr, cache ? &(*cache)[b] : nullptr);
  });
}

void render_path_backward_ranks(const Communicator& comm, const PathTracer& tracer, const Camera& camera,
                                const IntegratorSettings& settings, const Image& d_image, SceneGradients& grads,
                                const RenderControl& control, const std::vector<ReplayCache>* cache) {
  if (comm.size() == 1) {
    render_path_backward(tracer, camera, settings, d_image, grads, control, cache ? &(*cache)[0] : nullptr);
    return;
  }
  const std::vector<RowBand> bands = rank_row_bands(camera.height, comm);
  for (size_t b = 0; b < bands.size(); ++b)
    render_path_backward(tracer, band_camera(camera, bands[b]), settings, row_slice(d_image, bands[b]), grads, control,
                         cache ? &(*cache)[b] : nullptr);
}

void render_material_maps_ranks(const Communicator& comm, const SceneAccel& accel, const Camera& camera,
                                const AovSettings& settings, const RenderControl& control, Image* albedo,
                                Image* roughness, Image* coverage, MaterialMapWalks* walks) {
  if (comm.size() == 1) {
    render_material_maps(accel, camera, settings, control, albedo, roughness, coverage, walks);
    return;
  }
  // One gathered image of the three maps' five channels.
  Image all = render_row_bands(comm, camera, [&](const Camera& band, size_t) {
    Image a, r, c;
    render_material_maps(accel, band, settings, control, &a, &r, &c);
    Image packed(band.width, band.height, {"R", "G", "B", "Y", "A"});
    for (size_t p = 0, n = size_t(band.width) * band.height; p < n; ++p) {
      for (int k = 0; k < 3; ++k) packed.pixels[5 * p + k] = a.pixels[3 * p + k];
      packed.pixels[5 * p + 3] = r.pixels[p];
      packed.pixels[5 * p + 4] = c.pixels[p];
    }
    return packed;
  });
  *albedo = Image(camera.width, camera.height, {"R", "G", "B"});
  *roughness = Image(camera.width, camera.height, {"Y"});
  *coverage = Image(camera.width, camera.height, {"A"});
  for (size_t p = 0, n = size_t(camera.width) * camera.height; p < n; ++p) {
    for (int k = 0; k < 3; ++k) albedo->pixels[3 * p + k] = all.pixels[5 * p + k];
    roughness->pixels[p] = all.pixels[5 * p + 3];
    coverage->pixels[p] = all.pixels[5 * p + 4];
  }
}

void render_aov_backward_ranks(const Communicator& comm, const SceneAccel& accel, const Camera& camera,
                               const AovSettings& settings, const Image* d_albedo, const Image* d_roughness,
                               SceneGradients& grads, const MaterialMapWalks* walks) {
  if (comm.size() == 1) {
    render_aov_backward(accel, camera, settings, d_albedo, d_roughness, grads,
                        walks && !walks->pixels.empty() ? walks : nullptr);
    return;
  }
  for (const RowBand& band : rank_row_bands(camera.height, comm)) {
    Image da, dr;
    if (d_albedo) da = row_slice(*d_albedo, band);
    if (d_roughness) dr = row_slice(*d_roughness, band);
    render_aov_backward(accel, band_camera(camera, band), settings, d_albedo ? &da : nullptr,
                        d_roughness ? &dr : nullptr, grads);
  }
}

namespace {

// Visits every gradient buffer as (float*, count), in a fixed order.
template <class F>
void for_each_buffer(SceneGradients& g, F&& f) {
  f(reinterpret_cast<float*>(g.gaussian_albedo.data()), 3 * g.gaussian_albedo.size());
  f(g.gaussian_roughness.data(), g.gaussian_roughness.size());
  f(g.gaussian_metallic.data(), g.gaussian_metallic.size());
  f(reinterpret_cast<float*>(g.mesh_base_colour.data()), 3 * g.mesh_base_colour.size());
  f(g.mesh_roughness.data(), g.mesh_roughness.size());
  f(g.mesh_metallic.data(), g.mesh_metallic.size());
  f(g.environment.data(), g.environment.size());
}

static_assert(sizeof(Vec3) == 3 * sizeof(float), "Vec3 must be three packed floats");

}  // namespace

void allreduce_gradients(const Communicator& comm, SceneGradients& grads) {
  if (comm.size() == 1) return;
  std::vector<float> packed;
  for_each_buffer(grads, [&](float* p, size_t n) { packed.insert(packed.end(), p, p + n); });
  comm.allreduce_sum(packed.data(), packed.size());
  size_t at = 0;
  for_each_buffer(grads, [&](float* p, size_t n) {
    std::copy(packed.begin() + long(at), packed.begin() + long(at + n), p);
    at += n;
  });
}

}  // namespace ptir
