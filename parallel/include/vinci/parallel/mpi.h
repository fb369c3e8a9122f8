// The process-level side of vinci::parallel: is this process one of several started by `mpirun`
// (Open MPI), and the Distributor that goes with it. Linked by the `vinci` executable only
// (target vinci::parallel_mpi); the application libraries see distributor.h alone.
//
// Link order matters: Debian's Ipopt links sequential MUMPS, whose libraries export dummy
// MPI_Init / MPI_Comm_rank / MPI_Finalize / MPI_Wtime. An executable must list the real MPI
// library before Ipopt/MUMPS so that its MPI calls bind to Open MPI; MakeDistributor checks that
// the world it sees is the one mpirun announced and fails loudly otherwise.
#pragma once

#include <memory>

#include "vinci/parallel/distributor.h"

namespace vinci::parallel {

/// The number of processes mpirun started (Open MPI's OMPI_COMM_WORLD_SIZE), 1 if this process
/// was not started by mpirun. Throws std::invalid_argument if the variable is not a number ≥ 1.
int MpirunWorldSize();

/// True if this build has the MPI implementation (CMake option VINCI_MPI and MPI found).
bool MpiAvailable();

/// One per process. Started by mpirun with more than one process: an MPI distributor over
/// MPI_COMM_WORLD (MPI_Init_thread with MPI_THREAD_FUNNELED here, MPI_Finalize in its destructor;
/// only the calling thread talks to MPI, chunk functions may use threads of their own).
/// Otherwise (no mpirun, or `mpirun -np 1`) a LocalDistributor: no MPI initialization at all.
/// Throws std::invalid_argument if started by mpirun with several processes but built without
/// MPI, std::runtime_error if MPI does not see the world mpirun announced (size or rank differ:
/// e.g. MPI symbols bound to MUMPS' dummy MPI), std::logic_error if called twice with MPI.
std::unique_ptr<Distributor> MakeDistributor();

}  // namespace vinci::parallel
