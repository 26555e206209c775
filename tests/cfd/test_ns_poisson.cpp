// Pressure Poisson multigrid: manufactured solutions (second-order convergence of the discrete solution on uniform
// and stretched grids; periodic, Neumann and Dirichlet faces) and the grid-independent V-cycle convergence factor.
#include <gtest/gtest.h>
#include <cmath>
#include <functional>
#include <omp.h>
#include <algorithm>
#include "cfd/navier_stokes/multigrid.hpp"
#include "cfd/navier_stokes/poisson.hpp"
#include "cfd/navier_stokes/poisson_hypre.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::pi;
using Fn = std::function<double(double, double, double)>;

struct Case {
  ScalarBCs bc;
  Fn p, lap;  // exact solution and its Laplacian
  double lo, hi;
};

// Periodic box [0, 2 pi]^3: p = sin x cos y sin z.
Case periodic_case() {
  return {{ScalarBC::periodic, ScalarBC::periodic, ScalarBC::periodic, ScalarBC::periodic, ScalarBC::periodic, ScalarBC::periodic},
          [](double x, double y, double z) { return std::sin(x) * std::cos(y) * std::sin(z); },
          [](double x, double y, double z) { return -3 * std::sin(x) * std::cos(y) * std::sin(z); }, 0, 2 * pi};
}
// Unit box, Neumann everywhere: p = cos(pi x) cos(pi y) cos(pi z).
Case neumann_case() {
  return {{ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann},
          [](double x, double y, double z) { return std::cos(pi * x) * std::cos(pi * y) * std::cos(pi * z); },
          [](double x, double y, double z) { return -3 * pi * pi * std::cos(pi * x) * std::cos(pi * y) * std::cos(pi * z); },
          0, 1};
}
// Unit box, Dirichlet p = 0 at x = 1 (an outflow face), Neumann elsewhere: p = cos(pi x / 2) cos(pi y) cos(pi z).
Case dirichlet_case() {
  return {{ScalarBC::neumann, ScalarBC::dirichlet, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann},
          [](double x, double y, double z) { return std::cos(pi * x / 2) * std::cos(pi * y) * std::cos(pi * z); },
          [](double x, double y, double z) { return -2.25 * pi * pi * std::cos(pi * x / 2) * std::cos(pi * y) * std::cos(pi * z); },
          0, 1};
}

// Level 0, 1, 2 of a refinement family: uniform with 16, 32, 64 cells, or a fine box over the middle 20 %
// stretched outwards (h = L/40, ratio <= 1.1, refined as h/2, sqrt(ratio): 28, 56, 112 cells, widths h to 2.3 h).
Axis make_axis(const Case& c, int level, bool stretched, bool periodic) {
  if (!stretched) return Axis::uniform(c.lo, c.hi, 16 << level, periodic);
  const double L = c.hi - c.lo;
  StretchedAxis s{c.lo, c.hi, c.lo + 0.4 * L, c.lo + 0.6 * L, L / 40, 1.1, 4};
  for (int l = 0; l < level; ++l) s = s.refined();
  return Axis::stretched(s, periodic);
}

struct Result {
  double error;  // max-norm error of the discrete solution
  PoissonStats stats;
  int n;
};

Result solve(const Case& c, const Grid& g, double rtol = 1e-11, double stationary_factor = 0,
             PoissonBackend backend = PoissonBackend::multigrid, Field* solution = nullptr) {
  Poisson P(g, c.bc);
  Field x(g.shape()), b(g.shape()), exact(g.shape());
  const Shape s = g.shape();
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const auto p = g.centre(i, j, k);
        b(i, j, k) = c.lap(p[0], p[1], p[2]);
        exact(i, j, k) = c.p(p[0], p[1], p[2]);
      }
  PoissonOptions opt;
  opt.rtol = rtol;
  opt.max_cycles = 60;
  opt.stationary_factor = stationary_factor;
  opt.backend = backend;
  Result r{0, P.solve(x, b, opt), s.nx};
  const double shift = P.singular() ? mean(g, x) - mean(g, exact) : 0.0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const double e = std::abs(x(i, j, k) - shift - exact(i, j, k));
        r.error = std::isfinite(e) ? std::max(r.error, e) : HUGE_VAL;  // std::max alone would skip a NaN
        if (solution) (*solution)(i, j, k) = x(i, j, k) - shift;
      }
  return r;
}

// Errors on the three grids of the family.
std::vector<Result> study(const Case& c, bool stretched, double rtol = 1e-11, double stationary_factor = 0) {
  std::vector<Result> out;
  const bool periodic = c.bc[0] == ScalarBC::periodic;
  for (int level = 0; level < 3; ++level) {
    const Axis a = make_axis(c, level, stretched, periodic);
    out.push_back(solve(c, Grid(a, a, a), rtol, stationary_factor));
  }
  return out;
}

void expect_second_order(const std::vector<Result>& res, const char* what) {
  for (std::size_t m = 1; m < res.size(); ++m) {
    const double order = std::log(res[m - 1].error / res[m].error) / std::log(double(res[m].n) / res[m - 1].n);
    std::printf("  %s: n = %d, error %.3e, order %.2f\n", what, res[m].n, res[m].error, order);
    EXPECT_GE(order, 1.8) << what << ": errors " << res[m - 1].error << " (" << res[m - 1].n << ") -> " << res[m].error
                          << " (" << res[m].n << ")";
    EXPECT_TRUE(res[m].stats.converged) << what;
  }
}

// Tolerance: observed order >= 1.8 (second-order scheme, REFERENCE-free manufactured solution).
TEST(NavierStokesPoisson, SecondOrderPeriodicUniform) { expect_second_order(study(periodic_case(), false), "periodic uniform"); }
TEST(NavierStokesPoisson, SecondOrderPeriodicStretched) { expect_second_order(study(periodic_case(), true), "periodic stretched"); }
TEST(NavierStokesPoisson, SecondOrderNeumannStretched) { expect_second_order(study(neumann_case(), true), "neumann stretched"); }
TEST(NavierStokesPoisson, SecondOrderDirichletStretched) { expect_second_order(study(dirichlet_case(), true), "dirichlet stretched"); }

// Each V(2,2)-preconditioned conjugate-gradient iteration reduces the residual max-norm by a factor that stays
// nearly constant under refinement. Tolerances: <= 0.1 on uniform grids (measured 0.03-0.07), <= 0.2 on the
// stretched family (measured 0.08-0.15), growth over a 4x refinement <= 0.08 (measured up to 0.065: the point
// smoother loses a little on the cells of aspect ratio up to 2.4 that stretching in one direction creates).
TEST(NavierStokesPoisson, GridIndependentConvergenceFactor) {
  for (bool stretched : {false, true})
    for (const Case& c : {periodic_case(), neumann_case(), dirichlet_case()}) {
      const auto res = study(c, stretched);
      for (const auto& r : res) {
        EXPECT_LE(r.stats.factor(), stretched ? 0.2 : 0.1) << "n = " << r.n << (stretched ? " stretched" : " uniform");
        std::printf("  FCG-MG factor n=%d %s (x- face %s): %.3f (%d iterations to 1e-11)\n", r.n,
                    stretched ? "stretched" : "uniform", c.bc[1] == ScalarBC::dirichlet ? "Dirichlet" : "Neumann/periodic",
                    r.stats.factor(), r.stats.cycles);
      }
      EXPECT_LE(res[2].stats.factor(), res[0].stats.factor() + 0.08);
    }
}

// The default solve (PoissonOptions::stationary_factor = 0.1): plain V-cycle iterations while each cuts the
// residual at least tenfold, flexible CG from the first that does not. It must reach the same discrete solution
// as CG alone (errors against the manufactured solution equal to 1e-9 relative) in at most one iteration more,
// and start with a plain iteration. On these smooth right-hand sides the plain V(2,2) cycle alone reduces the
// max-norm residual only 0.16-0.19 per cycle (uniform) and 0.21-0.35 (stretched) (measured with
// stationary_factor = 1), so CG takes over after the first one or two: the hand-over costs at most one cycle.
TEST(NavierStokesPoisson, PlainMultigridIterationsHandOverToConjugateGradients) {
  for (bool stretched : {false, true})
    for (const Case& c : {periodic_case(), neumann_case(), dirichlet_case()}) {
      const auto cg = study(c, stretched, 1e-11, 0), hybrid = study(c, stretched, 1e-11, 0.1);
      for (std::size_t m = 0; m < cg.size(); ++m) {
        const PoissonStats &a = cg[m].stats, &h = hybrid[m].stats;
        std::printf("  n=%d %s (x- face %s): CG %d iterations, plain-then-CG %d (%d plain), factor %.3f\n", cg[m].n,
                    stretched ? "stretched" : "uniform", c.bc[1] == ScalarBC::dirichlet ? "Dirichlet" : "Neumann/periodic",
                    a.cycles, h.cycles, h.stationary, h.factor());
        EXPECT_TRUE(h.converged);
        EXPECT_NEAR(hybrid[m].error / cg[m].error, 1.0, 1e-9);
        EXPECT_LE(h.cycles, a.cycles + 1);
        EXPECT_GE(h.stationary, 1);
      }
    }
}

// What the plain iterations are for: the divergence an immersed body leaves is concentrated in a few cells next
// to its surface (high wavenumbers, which the smoother removes), and a projection needs it reduced 1000-fold.
// A dipole right-hand side in two neighbouring cells of a stretched walled box, rtol 1e-3 (the solver's
// default): every iteration plain, at most 3 (each V-cycle cuts the residual at least tenfold).
TEST(NavierStokesPoisson, LocalisedRightHandSideNeedsNoConjugateGradients) {
  const Case c = neumann_case();
  for (int level = 0; level < 3; ++level) {
    const Axis a = make_axis(c, level, true, false);
    const Grid g(a, a, a);
    Poisson P(g, c.bc);
    Field x(g.shape()), b(g.shape());
    const int i = g.shape().nx / 2, j = g.shape().ny / 3, k = g.shape().nz / 2;
    b(i, j, k) = 1 / g.volume(i, j, k);
    b(i + 1, j, k) = -1 / g.volume(i + 1, j, k);
    PoissonOptions opt;  // rtol 1e-6 by default
    opt.rtol = 1e-3;
    const PoissonStats st = P.solve(x, b, opt);
    std::printf("  dipole, stretched n=%d: %d iterations (%d plain), residual %.2e of the initial\n", g.shape().nx,
                st.cycles, st.stationary, st.residual / st.initial_residual);
    EXPECT_TRUE(st.converged);
    EXPECT_EQ(st.stationary, st.cycles);
    EXPECT_LE(st.cycles, 3);
  }
}

TEST(NavierStokesPoisson, RemovesNullSpaceOfIncompatibleRightHandSide) {
  const Case c = neumann_case();
  Grid g(Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false));
  Poisson P(g, c.bc);
  ASSERT_TRUE(P.singular());
  Field x(g.shape()), b(g.shape());
  b.fill(1.0);  // integral of b over the box is not the boundary flux (zero): no solution without projection
  const PoissonStats st = P.solve(x, b, PoissonOptions{});
  EXPECT_TRUE(st.converged);
  EXPECT_NEAR(mean(g, x), 0.0, 1e-14);
}

}  // namespace

// The V-cycle is the same on any number of threads: red-black Gauss-Seidel has no order within a colour, and the
// smoother's slabs (fused sweeps on walled boxes, one sweep at a time with periodic z ghosts) must honour every
// dependency between planes across slab ends. Bitwise equality over 1, 2, 3 and 5 threads on a stretched,
// odd-sized hierarchy (x: 46 -> 23 cells) with a Dirichlet face, and on a periodic box.
TEST(NavierStokesMultigrid, VCycleDoesNotDependOnThreadCount) {
  StretchedAxis sy{0, 1, 0.4, 0.6, 1.0 / 40, 1.1, 4};
  const Axis ax = Axis::uniform(0, 1, 46, false), ay = Axis::stretched(sy, false), az = Axis::uniform(0, 1, 48, false);
  const Axis px = Axis::uniform(0, 1, 46, true), pz = Axis::uniform(0, 1, 48, true);
  const ScalarBCs walls{ScalarBC::neumann, ScalarBC::dirichlet, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann};
  const ScalarBCs periodic{ScalarBC::periodic, ScalarBC::periodic, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::periodic, ScalarBC::periodic};
  const int saved = omp_get_max_threads();
  for (int c = 0; c < 2; ++c) {
    const Grid g = c == 0 ? Grid(ax, ay, az) : Grid(px, ay, pz);
    Multigrid M(g, c == 0 ? walls : periodic);
    const Shape s = g.shape();
    Field r(s), z1(s), z(s);
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) r(i, j, k) = std::sin(0.3 * i + 0.1 * j * j) * std::cos(0.7 * k) + (i == 7 && j == 5 ? 3.0 : 0.0);
    omp_set_num_threads(1);
    M.vcycle(r, z1, 2, 2);
    double zmax = 0;
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) zmax = std::max(zmax, std::abs(z1(i, j, k)));
    EXPECT_GT(zmax, 0.0);
    for (int t : {2, 3, 5}) {
      omp_set_num_threads(t);
      M.vcycle(r, z, 2, 2);
      int differ = 0;
      for (int k = 1; k <= s.nz; ++k)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) differ += z(i, j, k) != z1(i, j, k);
      EXPECT_EQ(differ, 0) << (c == 0 ? "walled" : "periodic") << " box, " << t << " threads";
    }
  }
  omp_set_num_threads(saved);
}

// A grid no direction of which can be coarsened (odd cell counts) has a one-level hierarchy: the "V-cycle" is
// the coarsest-level solve itself (Jacobi-preconditioned CG to 1e-3 here, 15 x 13 x 11 > the dense limit). It
// must still precondition: the solve converges to 1e-11 and the discrete solution has the manufactured
// solution's error level (second order: on the Neumann case with h = 1/15 the max error is ~1e-2 of the unit
// amplitude; tolerance 3e-2).
TEST(NavierStokesPoisson, OneLevelGridStillPreconditions) {
  const Case c = neumann_case();
  const Grid g(Axis::uniform(0, 1, 15, false), Axis::uniform(0, 1, 13, false), Axis::uniform(0, 1, 11, false));
  EXPECT_EQ(Multigrid(g, c.bc).levels(), 1);
  const Result r = solve(c, g);
  std::printf("  one-level grid 15 x 13 x 11: %d iterations, converged %d, max error %.3e\n", r.stats.cycles,
              int(r.stats.converged), r.error);
  EXPECT_TRUE(r.stats.converged);
  EXPECT_LE(r.stats.cycles, 30);
  EXPECT_LE(r.error, 3e-2);
}

namespace {

// hypre's PCG + SMG (the alternative back end) solves the same discrete problem: on the manufactured cases (Neumann
// and Dirichlet faces on the stretched 56^3 grid, periodic faces on a uniform 32^3 one) its solution equals the
// multigrid's to 1e-8 of the solution's size at a max-norm residual of 1e-11 of the right-hand side (both are the
// discrete solution). A periodic axis whose cell count is not a power of two is refused.
TEST(NavierStokesPoisson, HypreBackendSolvesTheSameDiscreteProblem) {
  if (!hypre_available()) GTEST_SKIP() << "built without hypre";
  for (const Case& c : {periodic_case(), neumann_case(), dirichlet_case()}) {
    const bool periodic = c.bc[0] == ScalarBC::periodic;
    // a periodic axis needs a power-of-two cell count for hypre (refused otherwise, below): uniform 32^3 there
    const Axis a = make_axis(c, 1, !periodic, periodic);
    const Grid g(a, a, a);
    Field mg(g.shape()), hy(g.shape());
    const Result rm = solve(c, g, 1e-11, 0, PoissonBackend::multigrid, &mg);
    const Result rh = solve(c, g, 1e-11, 0, PoissonBackend::hypre, &hy);
    EXPECT_TRUE(rm.stats.converged);
    EXPECT_TRUE(rh.stats.converged);
    double diff = 0, size = 0;
    const Shape s = g.shape();
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          diff = std::max(diff, std::abs(mg(i, j, k) - hy(i, j, k)));
          size = std::max(size, std::abs(mg(i, j, k)));
        }
    std::printf("  %s faces: multigrid %d iterations, hypre %d; max difference %.2e of max|x|; errors %.3e, %.3e\n",
                periodic ? "periodic" : c.bc[1] == ScalarBC::dirichlet ? "Dirichlet" : "Neumann", rm.stats.cycles,
                rh.stats.cycles, diff / size, rm.error, rh.error);
    EXPECT_LT(diff, 1e-8 * size);
  }
  const Case c = periodic_case();
  const Axis a = make_axis(c, 1, true, true);  // 56 cells
  EXPECT_THROW(solve(c, Grid(a, a, a), 1e-11, 0, PoissonBackend::hypre), std::invalid_argument);
}

// The grid of the 2-D hovering wing in a box of +-30 chords: a two-cell periodic slab (depth 2h) whose x-y cells grow
// by 5 % per cell to 23 h outside the fine box, so far cells are 23 times longer than deep. A right-hand side with
// every wavelength (a fixed pseudo-random field of zero mean): the project's multigrid (point smoother) stalls
// (measured: 30 iterations, residual 9.4e5 times the target), hypre's SMG (plane smoothing) converges (9).
TEST(NavierStokesPoisson, HypreConvergesOnAThinSlabWithElongatedCells) {
  if (!hypre_available()) GTEST_SKIP() << "built without hypre";
  const double h = 1.0 / 16;
  const Axis ax = Axis::stretched(StretchedAxis{-30, 30, -2, 2, h, 1.05, 8}, false);
  const Axis ay = Axis::stretched(StretchedAxis{-30, 30, -3, 1, h, 1.05, 8}, false);
  const Grid g(ax, ay, Axis::uniform(0, 2 * h, 2, true));
  const ScalarBCs bc{ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::neumann, ScalarBC::periodic,
                     ScalarBC::periodic};
  const Shape s = g.shape();
  Field b0(s);
  unsigned state = 12345u;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        state = state * 1664525u + 1013904223u;
        b0(i, j, k) = double(state >> 8) / double(1u << 24) - 0.5;
      }
  PoissonStats st[2];
  for (int m = 0; m < 2; ++m) {
    Poisson P(g, bc);
    Field x(s), b = b0;
    PoissonOptions opt;
    opt.backend = m == 0 ? PoissonBackend::multigrid : PoissonBackend::hypre;
    st[m] = P.solve(x, b, opt);
  }
  std::printf("  slab %d x %d x %d: multigrid %d iterations, residual %.2e of the target (%s); hypre %d, %.2e (%s)\n",
              s.nx, s.ny, s.nz, st[0].cycles, st[0].residual / st[0].target, st[0].converged ? "converged" : "not converged",
              st[1].cycles, st[1].residual / st[1].target, st[1].converged ? "converged" : "not converged");
  EXPECT_TRUE(st[1].converged);
}

}  // namespace
