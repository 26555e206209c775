// MPI started once per process (mpi_start.hpp).
#include "cfd/navier_stokes/mpi_start.hpp"

#if defined(FLAPSTAB_HAVE_MPI) || defined(FLAPSTAB_HAVE_HYPRE)
#define OMPI_SKIP_MPICXX 1  // the C interface only (no libmpi_cxx)
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#include <cstdlib>

namespace flapstab::ns {

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
        if (!finalised) MPI_Finalize();
      });
    }
    return true;
  }();
  (void)started;
}

}  // namespace flapstab::ns
#endif
