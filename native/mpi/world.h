// The communicator of the whole job for the `ptir` binary (core/communicator.h).
//
// Built with MPI (CMake PTIR_WITH_MPI, world.cpp): when the process was started by
// an MPI launcher (mpirun/mpiexec, or Slurm's srun with PMIx/PMI) MPI is
// initialised and the world is MPI_COMM_WORLD; otherwise -- and always in a build
// without MPI -- it is the single process, and nothing of MPI is touched.
#pragma once

#include "ptir/core/communicator.h"

namespace ptir {

// Call once, first thing in main (MPI_Init_thread, FUNNELED: only the main thread talks).
const Communicator& init_world(int* argc, char*** argv);
const Communicator& world();  // single_process() before init_world
void finalize_world();        // MPI_Finalize (after the last collective)
// "Open MPI v4.1.4" or "none": what this binary was built with.
const char* world_library();

}  // namespace ptir
