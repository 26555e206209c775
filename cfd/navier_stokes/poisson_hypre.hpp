// hypre's structured multigrid as the pressure solver's alternative back end (PoissonOptions::backend): conjugate
// gradients preconditioned by one SMG V-cycle (Schaffer 1998, SIAM J Sci Comput 20:228; hypre reference manual,
// "Struct SMG"), on one MPI rank (MPI_COMM_SELF: the copies of a campaign solve their own flows) or over the ranks of
// a decomposition (its communicator, each rank giving its z slab). SMG smooths whole planes and lines, so it converges
// on grids with very elongated cells where the project's point smoother stalls (tests/cfd/test_ns_poisson.cpp, a
// thin slab with cells 23 times longer than deep). A periodic axis needs a power-of-two cell count (refused
// otherwise). Built when CMake finds hypre and MPI (FLAPSTAB_HAVE_HYPRE); otherwise hypre_available() is false and
// constructing one throws.
#pragma once
#include <memory>
#include "cfd/navier_stokes/field.hpp"
#include "cfd/navier_stokes/stencil.hpp"

namespace flapstab::ns {

bool hypre_available();

class HyprePoisson {
 public:
  // The matrix is -V L (V the cell volume: symmetric positive semi-definite), set up once; MPI is initialised on
  // first use if the program has not done it (and finalised at exit).
  // L: this rank's stencil. slab: its planes of a decomposed z axis of whole_nz cells (periodic or not); null on one
  // rank.
  // slab: this rank's part of the whole z axis (whole_nz cells) over the ranks of `comm` (a pointer to an MPI_Comm,
  // Decomposition::communicator(); null: MPI_COMM_WORLD); without a slab, one rank on MPI_COMM_SELF.
  explicit HyprePoisson(const Stencil<real>& L, const Slab* slab = nullptr, int whole_nz = 0, bool z_periodic = false,
                        const void* comm = nullptr);
  ~HyprePoisson();
  HyprePoisson(const HyprePoisson&) = delete;
  HyprePoisson& operator=(const HyprePoisson&) = delete;

  // x = L^-1 b (b compatible when L is singular) until the 2-norm of -V (b - L x) falls rtol-fold against that of
  // -V b, or max_iterations; from x's value on entry with `guess`, else from zero. Returns the iterations.
  int solve(Field& x, const Field& b, double rtol, int max_iterations, bool guess);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace flapstab::ns
