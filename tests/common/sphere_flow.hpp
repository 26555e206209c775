// The steady-sphere case of the immersed-boundary validation, shared by its tests (drag, force partitioning):
// D = 1, U = 1, Re = U D / nu = 100. Domain [-5, 15] x [-5, 5]^2 D, fine box [-0.8, 1.6] x [-0.8, 0.8]^2 with
// spacing h, geometric stretching (ratio) outside. Uniform inflow U at x-, zero-gradient outflow at x+, velocity U
// on the lateral faces; impulsive start from the uniform flow. The sphere (cube-sphere mesh of n divisions) is fixed
// at the origin.
#pragma once
#include <memory>
#include "cfd/navier_stokes/immersed.hpp"

namespace flapstab::testing {

struct SphereInStream {
  ns::Grid grid;
  ns::Solver solver;
  ns::ImmersedBoundary ib;

  SphereInStream(double h, double ratio, int mesh_n, bool hypre = false, double reynolds = 100)
      : grid(ns::Axis::stretched(ns::StretchedAxis{-5, 15, -0.8, 1.6, h, ratio, 8}, false),
             ns::Axis::stretched(ns::StretchedAxis{-5, 5, -0.8, 0.8, h, ratio, 8}, false),
             ns::Axis::stretched(ns::StretchedAxis{-5, 5, -0.8, 0.8, h, ratio, 8}, false)),
        solver(grid, boundaries(), options(hypre, reynolds)),
        ib(grid) {
    solver.initialise([](double, double, double) { return Vec3(1, 0, 0); });
    ib.add_part(ns::sphere_mesh(0.5, mesh_n), ns::fixed_part());
    ib.attach(solver);
  }

  static ns::Boundaries boundaries() {
    ns::Boundaries bc = ns::Boundaries::all(ns::BC::velocity);
    for (auto& f : bc.face) f.velocity = [](double) { return Vec3(1, 0, 0); };
    bc.face[ns::face(0, 1)] = {ns::BC::outflow, {}, {}};
    return bc;
  }
  // hypre: pressure solves by hypre, which converge on the elongated cells of finer grids (the point smoother of the
  // project's multigrid stalls at aspect ratios near 30)
  static ns::SolverOptions options(bool hypre = false, double reynolds = 100) {
    ns::SolverOptions opt;
    if (hypre) opt.poisson.backend = ns::PoissonBackend::hypre;
    opt.nu = 1.0 / reynolds;
    opt.cfl = 1.2;
    opt.keep_stage_velocities = true;  // for force partitioning with the forced region as the body
    return opt;
  }
};

}  // namespace flapstab::testing
