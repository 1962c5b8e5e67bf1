// The optimiser's iteration split across the ranks of a data-parallel run
// (`mpirun -np N ptir optimize`; core/communicator.h, render/row_bands.h).
//
// Decision: rows of every view, not whole views per rank. With the default one
// view per iteration a split by views would leave N - 1 ranks idle; rows balance
// any views-per-iteration. The price is the gather of each view's images (9 floats
// a pixel) and the loss computed on every rank: -3 to +9 % at 2 ranks on this
// machine's 2 cores, within its noise (bench/bench_mpi.py, three runs).
//
// Every view of an iteration is split into row bands (render_row_bands): each rank
// renders its bands of the primal image and of the primary-hit material maps,
// and every rank gets the whole images, so the losses (D-SSIM's window crosses
// band edges), the masks and the image adjoints are computed whole, identically,
// on every rank. Each rank then replays only its own bands into its gradient
// buffers, and allreduce_gradients sums the ranks' buffers once per iteration,
// after the last view, in rank order (Communicator::allreduce_sum). So every rank
// holds the same gradients and takes the same Adam step; the parameters never
// need to be sent.
//
// Compared with one process, the gradient is the same sum of the same per-sample
// terms, grouped differently (per band and rank, then ranks in order): equal up
// to float re-association, and to the last-bit differences of jittered camera
// rays in a band (render/row_bands.h); the material maps are bit-identical.
// tests/python/test_mpi.py measures both. Every rank holds the same bits, so a
// run is deterministic for a given N and thread count. With one rank every
// function here is the plain single-process call.
#pragma once

#include <vector>

#include "ptir/core/communicator.h"
#include "ptir/render/aov.h"
#include "ptir/render/material_maps.h"
#include "ptir/render/replay_cache.h"
#include "ptir/transport/gradients.h"
#include "ptir/transport/path_tracer.h"

namespace ptir {

// render_path of the whole view on every rank; each rank renders its bands and,
// with `cache`, keeps what their replay reuses, one ReplayCache per band of
// rank_row_bands (the vector is resized to them; an entry's walk store, when it
// has one, is kept).
Image render_path_ranks(const Communicator& comm, const PathTracer& tracer, const Camera& camera,
                        const IntegratorSettings& settings, const RenderControl& control,
                        std::vector<ReplayCache>* cache);
// render_path_backward of this rank's bands of d_image (whole-image size), reading
// `cache` (what render_path_ranks kept, or null); adds to grads.
void render_path_backward_ranks(const Communicator& comm, const PathTracer& tracer, const Camera& camera,
                                const IntegratorSettings& settings, const Image& d_image, SceneGradients& grads,
                                const RenderControl& control, const std::vector<ReplayCache>* cache);
// render_material_maps (material_maps.h) of the whole view on every rank; on one
// rank, `walks` (optional) keeps the walks for render_aov_backward_ranks (with
// several ranks it is left empty, and the adjoint traces again).
void render_material_maps_ranks(const Communicator& comm, const SceneAccel& accel, const Camera& camera,
                                const AovSettings& settings, const RenderControl& control, Image* albedo,
                                Image* roughness, Image* coverage, MaterialMapWalks* walks = nullptr);
// render_aov_backward of this rank's bands; adds to grads. `walks`: what
// render_material_maps_ranks kept (used on one rank, when it kept any).
void render_aov_backward_ranks(const Communicator& comm, const SceneAccel& accel, const Camera& camera,
                               const AovSettings& settings, const Image* d_albedo, const Image* d_roughness,
                               SceneGradients& grads, const MaterialMapWalks* walks = nullptr);
// grads = the sum of every rank's grads (one allreduce of all buffers packed together).
void allreduce_gradients(const Communicator& comm, SceneGradients& grads);

}  // namespace ptir
