// MPI started once per process by flapstab itself (the decomposition over ranks, the hypre back end), and finalised
// at exit when flapstab started it. Built when flapstab links MPI (FLAPSTAB_HAVE_MPI or FLAPSTAB_HAVE_HYPRE).
#pragma once

namespace flapstab::ns {

// Initialises MPI (MPI_THREAD_FUNNELED) unless it is already initialised, and registers MPI_Finalize at exit when it
// did; further calls do nothing.
void start_mpi();

}  // namespace flapstab::ns
