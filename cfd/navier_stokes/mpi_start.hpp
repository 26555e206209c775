// MPI started once per process by flapstab itself (the decomposition over ranks, the hypre back end), and finalised
// at exit when flapstab started it. Built when flapstab links MPI (FLAPSTAB_HAVE_MPI or FLAPSTAB_HAVE_HYPRE).
#pragma once

namespace flapstab::ns {

// Initialises MPI (MPI_THREAD_FUNNELED) unless it is already initialised, and registers MPI_Finalize at exit when it
// did; further calls do nothing.
void start_mpi();

// Completes a non-blocking MPI operation (`request` points at its MPI_Request) without spinning on the core, as Open
// MPI's blocking calls do: polled, yielding at first (a quick answer costs no sleep), then every 2 ms. For waits that
// may last minutes (a rank whose rank 0 waits for a file lock, a group done before the others).
void wait_without_spinning(void* request);

}  // namespace flapstab::ns
