// Geometric multigrid V-cycle for the MAC Laplacian on the non-uniform grid, in single precision: the
// preconditioner of the pressure solver (poisson.hpp).
#pragma once
#include <memory>
#include <vector>
#include "cfd/navier_stokes/stencil.hpp"

namespace flapstab::ns {

// Cell-centred multigrid: a direction is coarsened by 2 (every other face kept) while its cell count is even and
// its spacing within 2x the finest direction's (semi-coarsening otherwise); coarse operators are rediscretised on
// the coarse faces; restriction is the volume-weighted mean of the residual, prolongation linear interpolation in
// the cell-centre coordinates; smoothing by over-relaxed red-black Gauss-Seidel; the coarsest level by dense LU
// (or Jacobi-preconditioned CG when it is large). Single precision halves the memory traffic; the Krylov solver
// that it preconditions works in double, so the solution does not lose accuracy.
//
// Over several ranks (decomposition.hpp) the fine levels are split into z slabs: each red-black half-sweep exchanges
// the ghost planes of the colour it updated, restriction and prolongation stay within a rank (slabs are whole
// blocks of z_unit() planes, so a coarse cell's fine cells live on one rank). The first level whose z spacing has
// grown by z_unit() is gathered on every rank (agglomeration), which then runs the rest of the cycle on the whole
// level, as a single rank would, and prolongs from its own planes. Every cell sees the same arithmetic as on one
// rank: the V-cycle's result is the single-rank result bit for bit.
class Multigrid {
 public:
  // g, bc: the whole grid and its conditions; with a decomposition over several ranks the levels are this rank's
  // slabs of them (level 0: slab(g.axis[2].n, z_unit(g, ranks), periodic)).
  Multigrid(const Grid& g, const ScalarBCs& bc, std::shared_ptr<const Decomposition> dec = {});
  ~Multigrid();
  Multigrid(Multigrid&&) noexcept;
  Multigrid& operator=(Multigrid&&) noexcept;

  // z = one V(pre, post) cycle for L z = r from z = 0 (r, z: fields of the fine grid, z's ghosts not set).
  void vcycle(const Field& r, Field& z, int pre, int post);
  int levels() const;
  const Shape& level_shape(int l) const;
  // The planes of a rank's slab come in blocks of this many: the largest z coarsening factor of the hierarchy of
  // g whose blocks share out over `ranks` within 10 %, else the one that shares them out most evenly (1 when z
  // never coarsens or has fewer than 2 planes per rank).
  static int z_unit(const Grid& g, int ranks);
  // This rank's slab of g's z axis (the whole axis on one rank).
  static Slab rank_slab(const Grid& g, const Decomposition& dec);
  int gathered_level() const { return gathered_; }  // the first level every rank holds whole (-1: one rank)

  struct Level;

 private:
  void cycle(int l, int pre, int post, const real* r, real* z);
  void exchange(Level& V) const;
  std::vector<Level> levels_;
  ScalarBCs bc_;
  bool singular_;
  std::shared_ptr<const Decomposition> dec_;
  int gathered_ = -1;
  std::vector<std::vector<Slab>> slabs_;  // per level below gathered_: every rank's slab
};

}  // namespace flapstab::ns
