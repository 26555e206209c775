// MPI started once per process (mpi_start.hpp).
#include "cfd/navier_stokes/mpi_start.hpp"

#if defined(FLAPSTAB_HAVE_MPI) || defined(FLAPSTAB_HAVE_HYPRE)
#define OMPI_SKIP_MPICXX 1  // the C interface only (no libmpi_cxx)
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#include <chrono>
#include <cstdlib>
#include <thread>

namespace flapstab::ns {

void wait_without_spinning(void* request) {
  auto* r = static_cast<MPI_Request*>(request);
  for (int done = 0, polls = 0;; ++polls) {
    MPI_Test(r, &done, MPI_STATUS_IGNORE);
    if (done) return;
    if (polls < 1000) std::this_thread::yield();
    else std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

void start_mpi() {
  static const bool started = [] {
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (!initialised) {
      int provided = 0;
      MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
      std::atexit([] {
        int finalised = 0;
        MPI_Finalized(&finalised);
        if (finalised) return;
        // Every rank at the end, waited for without spinning: a group of ranks done with its flows (a campaign,
        // Decomposition::split) must not take the cores of a group still computing while MPI_Finalize waits for it.
        MPI_Request request;
        MPI_Ibarrier(MPI_COMM_WORLD, &request);
        wait_without_spinning(&request);
        MPI_Finalize();
      });
    }
    return true;
  }();
  (void)started;
}

}  // namespace flapstab::ns
#endif
