// Laplace problems in the fluid part of a CFD grid with Neumann conditions on immersed bodies: the influence
// potentials of force partitioning (docs/theory/force-partitioning.md).
//
// Discretisation: cut cells (geometry.hpp). In the volume-integrated form
//   (A phi)_c = sum over the faces f of c of a_f (phi_c - phi_nb),   a_f = beta_f A_f / df_f
// (beta_f the face's open fraction, A_f its area, df_f the centre spacing across it); the domain's faces carry no
// conductance. A Neumann datum g = d phi / dn (n out of the body, into the fluid) on the surface piece in a cell
// enters the right-hand side as -int g dS (the flux out of the fluid).
// The discrete Green identity sum_c phi_c (A phi)_c = sum_open a_f (phi_c - phi_nb)^2 holds exactly, so the
// partition's discrete integrals inherit the continuous identities (docs/theory).
//
// Solver: conjugate gradients in double precision preconditioned by a geometric multigrid V-cycle in single
// precision (flexible: the coarsest level is relaxed to a tolerance, and the V-cycle rounds to float), several
// right-hand sides at once. Coarse conductances sum the fine faces' open area over the coarse centre spacing,
// a_C = sum_f a_f df_f / df_C (the coarse-grid discretisation where everything is open, so walls coarsen as
// their open fraction); piecewise-constant prolongation, summed restriction, red-black over-relaxed Gauss-Seidel
// smoothing (four sweeps with omega = 1.4 before and after the coarse correction: with this weak prolongation the
// smoothing carries the convergence).
#pragma once
#include <array>
#include <cstddef>
#include <memory>
#include <vector>
#include "cfd/fpm/geometry.hpp"

namespace flapstab::fpm {

using ns::Field;
using ns::Grid;
using ns::Shape;

struct LaplaceStats {
  int iterations = 0;
  double initial_residual = 0, residual = 0;  // max-norm of b - A x over active cells (volume-integrated units)
  bool converged = false;
};

class NeumannLaplacian {
 public:
  // Throws std::invalid_argument for a periodic axis with an odd cell count (the red-black colouring needs even).
  NeumannLaplacian(const Grid& g, const FluidGeometry& geometry);
  ~NeumannLaplacian();
  NeumannLaplacian(NeumannLaplacian&&) noexcept;
  NeumannLaplacian& operator=(NeumannLaplacian&&) noexcept;

  // Solves A x = b from x's value on entry (a warm start: the previous sample's potential) until
  // max|b - A x| <= rtol max|b|. b must be compatible (sum over each connected fluid region zero); its mean over
  // the active cells is removed first. Inactive cells (solid, or fluid without an open face) get x = 0.
  LaplaceStats solve(Field& x, const Field& b, double rtol = 1e-8, int max_iterations = 500) const;
  // The same for several right-hand sides at once (each to its own tolerance, with its own statistics): they share
  // the operator, so every sweep of the preconditioner reads the conductances once for up to max_block of them.
  static constexpr std::size_t max_block = 8;
  std::vector<LaplaceStats> solve(const std::vector<Field*>& xs, const std::vector<const Field*>& bs,
                                  double rtol = 1e-8, int max_iterations = 500) const;
  // Takes over the work arrays of an operator on the same grid (the previous sample's), instead of allocating.
  void take_workspace(NeumannLaplacian& previous);
  // (A x) on the cells; x's periodic ghosts are refreshed first.
  void apply(Field& x, Field& Ax) const;
  // Conductance a_f of face I (the lower face of cell I) along axis d; 0 where closed.
  double conductance(int d, int i, int j, int k) const;
  bool active(int i, int j, int k) const;
  int levels() const;
  std::size_t bytes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Periodic images into the ghost layer of a cell field (axes that are not periodic keep their ghosts).
void fill_periodic_ghosts(const Grid& g, Field& x);

}  // namespace flapstab::fpm
