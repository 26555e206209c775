// Geometric multigrid V-cycle for the MAC Laplacian on the non-uniform grid, in single precision: the
// preconditioner of the pressure solver (poisson.hpp).
#pragma once
#include <vector>
#include "cfd/navier_stokes/stencil.hpp"

namespace flapstab::ns {

// Cell-centred multigrid: a direction is coarsened by 2 (every other face kept) while its cell count is even and
// its spacing within 2x the finest direction's (semi-coarsening otherwise); coarse operators are rediscretised on
// the coarse faces; restriction is the volume-weighted mean of the residual, prolongation linear interpolation in
// the cell-centre coordinates; smoothing by over-relaxed red-black Gauss-Seidel; the coarsest level by dense LU
// (or Jacobi-preconditioned CG when it is large). Single precision halves the memory traffic; the Krylov solver
// that it preconditions works in double, so the solution does not lose accuracy.
class Multigrid {
 public:
  Multigrid(const Grid& g, const ScalarBCs& bc);
  ~Multigrid();
  Multigrid(Multigrid&&) noexcept;
  Multigrid& operator=(Multigrid&&) noexcept;

  // z = one V(pre, post) cycle for L z = r from z = 0 (r, z: fields of the fine grid, z's ghosts not set).
  void vcycle(const Field& r, Field& z, int pre, int post);
  int levels() const;
  const Shape& level_shape(int l) const;

  struct Level;

 private:
  void cycle(int l, int pre, int post, const real* r, real* z);
  std::vector<Level> levels_;
  ScalarBCs bc_;
  bool singular_;
};

}  // namespace flapstab::ns
