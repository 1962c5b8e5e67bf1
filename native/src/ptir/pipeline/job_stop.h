// How a data-parallel job (`mpirun -np N ptir optimize`) ends when it is stopped
// from outside: a rank that died, mpirun's Ctrl-C, Slurm's scancel or a time limit.
//
// Decision: under MPI a SIGINT/SIGTERM ends the rank at once, after rank 0 has
// printed the current stop message (which names the last checkpoint). A rank
// cannot stop "after the current iteration" alone -- the others would wait for it
// in the next collective -- and the launcher ends the remaining ranks anyway. The
// checkpoint is written atomically every --checkpoint-every iterations, so the
// last one is always whole: --resume continues from it with any number of ranks.
#pragma once

#include <string>

namespace ptir::pipeline {

// Installs the SIGINT/SIGTERM handlers; only rank 0 (`print`) writes the message.
void install_job_stop_handlers(bool print);
// The line printed on a stop from now on (formatted here, written by the handler
// with write(2) alone).
void set_job_stop_message(const std::string& line);

}  // namespace ptir::pipeline
