// Pressure Poisson equation L x = b (L = D G, the MAC divergence of the MAC gradient): conjugate gradients
// preconditioned by a geometric multigrid V-cycle.
#pragma once
#include <memory>
#include "cfd/navier_stokes/multigrid.hpp"

namespace flapstab::ns {

class HyprePoisson;

// The solver behind Poisson::solve: the project's multigrid-preconditioned CG (default), or hypre's structured
// PCG + SMG (poisson_hypre.hpp; for grids with very elongated cells, where the point smoother stalls).
enum class PoissonBackend { multigrid, hypre };

struct PoissonOptions {
  PoissonBackend backend = PoissonBackend::multigrid;
  double rtol = 1e-6;   // stop when max|b - Lx| <= max(rtol * max|b|, atol)
  double atol = 0;
  int max_cycles = 30;  // iterations, plain and conjugate-gradient (one V-cycle each)
  int pre_sweeps = 2;   // red-black Gauss-Seidel sweeps before and after the coarse-grid correction
  int post_sweeps = 2;
  // Plain V-cycle iterations first, as long as each reduces the residual at least this much (max-norm ratio);
  // then flexible CG. 0: CG from the start. A plain iteration moves about 60 % of the bytes of a CG one
  // (99 against 171 per cell on walled boxes in bench/step_timing.hpp's model).
  double stationary_factor = 0.1;
};

struct PoissonStats {
  int cycles = 0;                // iterations (V-cycles)
  int stationary = 0;            // of which plain multigrid iterations (the rest flexible CG)
  double initial_residual = 0;   // max-norm, after removing the null space from b
  double residual = 0;
  double target = 0;             // the residual asked for: max(rtol max|b|, atol)
  bool converged = false;
  bool breakdown = false;        // a non-finite CG step (NaN or infinite values in r): stopped without updating x
  double factor() const;         // mean residual reduction per iteration
};

// Plain multigrid iterations (x += M r with one single-precision V-cycle M, multigrid.hpp) while each cuts the
// residual at least stationary_factor-fold, then flexible conjugate gradients in double precision preconditioned
// by the same V-cycle. The divergence a moving body leaves is local and the smoother removes it fast (two or
// three plain iterations per projection on the insect grids, each at about 60 % of a CG iteration's memory
// traffic); on smooth right-hand sides and stretched cells the Krylov acceleration keeps the rate
// (0.05-0.15 per iteration against 0.16-0.35 for plain cycles). Periodic and Neumann faces everywhere make L
// singular: b's volume-weighted mean is removed.
class Poisson {
 public:
  // g, bc: the whole grid and its conditions. With a decomposition over several ranks the unknowns are this rank's
  // slab (slab()): fields passed in have its shape, and the norms and inner products are global.
  Poisson(const Grid& g, const ScalarBCs& bc, std::shared_ptr<const Decomposition> dec = {});
  ~Poisson();
  Poisson(Poisson&&) noexcept;
  Poisson& operator=(Poisson&&) noexcept;

  // x = L^-1 b to the residual tolerance (relative to b), from x = 0 or, with `guess`, from x's value on entry
  // (the previous time step's pressure increment of the same stage saves one or two iterations). Singular L: x
  // is defined up to a constant. b is overwritten (by the residual). On return x's ghosts hold the boundary
  // conditions, ready for the gradient.
  PoissonStats solve(Field& x, Field& b, const PoissonOptions& opt, bool guess = false);
  // Lx = L x on the cells (x's ghosts are filled first).
  void apply(Field& x, Field& Lx) const;
  double residual_norm(Field& x, const Field& b) const;  // max over cells of |b - L x|
  bool singular() const { return singular_; }
  const Slab& slab() const { return slab_; }
  const ScalarBCs& local_conditions() const { return bc_; }  // bc with the slab's cuts as interfaces
  const Multigrid& multigrid() const { return mg_; }
  std::size_t bytes() const;  // memory held (Krylov vectors and multigrid levels)

 private:
  void ghosts(Field& x) const;  // box conditions and the slab's exchange
  std::shared_ptr<const Decomposition> dec_;
  Slab slab_;
  ScalarBCs bc_;
  Stencil<real> L_;
  Multigrid mg_;
  bool singular_;
  Field z_, p_, q_;  // preconditioned residual, search direction, L p
  std::unique_ptr<HyprePoisson> hypre_;  // set up at the first solve with backend = hypre
  int whole_nz_;                          // the whole grid's z axis (hypre's grid over ranks)
  bool z_periodic_;
};

// Volume-weighted mean of a cell field.
double mean(const Grid& g, const Field& f);

}  // namespace flapstab::ns
