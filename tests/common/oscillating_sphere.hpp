// The oscillating-sphere case of the immersed-boundary validation, shared by its tests (Stokes force, force
// partitioning): R = 0.5, omega = 2 pi, R/delta = 2 (nu = delta^2 omega / 2), amplitude A = 0.05 R, u_b = u0 sin(omega t)
// with u0 = A omega (Re = u0 D / nu = 0.8). Box [-4, 4]^3 (8 R from the centre), fine box [-0.8, 0.8]^3 of spacing h,
// stretched by <= 1.1 outside; fixed dt, a whole number of steps per period within the diffusion limit. Moving: the
// sphere oscillates in fluid at rest between walls at rest; fixed: the sphere is at rest and the walls move with
// U(t) = -u_b(t).
#pragma once
#include <cmath>
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/navier_stokes/operators.hpp"

namespace flapstab::testing {

struct OscillatingSphere {
  static constexpr double R = 0.5, omega = 2 * 3.14159265358979323846, delta = R / 2, nu = delta * delta * omega / 2,
                          A = 0.05 * R, u0 = A * omega;
  ns::Grid grid;
  int per_period;
  ns::Solver solver;
  ns::ImmersedBoundary ib;

  OscillatingSphere(double h, bool moving, int mesh_n)
      : grid(axis(h), axis(h), axis(h)),
        per_period(int(std::ceil(1.0 / (0.5 / ns::max_viscous_rate(grid, nu)) / 8)) * 8),
        solver(grid, boundaries(moving), options(per_period)),
        ib(grid) {
    solver.initialise([](double, double, double) { return Vec3::Zero(); });
    if (moving)
      ib.add_part(ns::sphere_mesh(R, mesh_n), [](double t) { return state(t); });
    else
      ib.add_part(ns::sphere_mesh(R, mesh_n), ns::fixed_part());
    ib.attach(solver);
  }
  // The moving sphere's kinematics: centre A (1 - cos omega t) on x, velocity u_b, acceleration u0 omega cos omega t.
  static ns::PartState state(double t) {
    const Vec3 c(A * (1 - std::cos(omega * t)), 0, 0);
    ns::PartState s{ns::RigidTransform{Mat3::Identity(), c},
                    ns::RigidVelocity{c, Vec3(u0 * std::sin(omega * t), 0, 0), Vec3::Zero()}};
    s.acceleration = Vec3(u0 * omega * std::cos(omega * t), 0, 0);
    return s;
  }
  static ns::Axis axis(double h) { return ns::Axis::stretched(ns::StretchedAxis{-4, 4, -0.8, 0.8, h, 1.1, 8}, false); }
  static ns::Boundaries boundaries(bool moving) {
    ns::Boundaries bc = ns::Boundaries::all(ns::BC::velocity);
    if (!moving)
      for (auto& f : bc.face) f.velocity = [](double t) { return Vec3(-u0 * std::sin(omega * t), 0, 0); };
    return bc;
  }
  static ns::SolverOptions options(int per_period) {
    ns::SolverOptions opt;
    opt.nu = nu;
    opt.dt = 1.0 / per_period;
    opt.keep_stage_velocities = true;  // for force partitioning with the forced region as the body
    return opt;
  }
};

}  // namespace flapstab::testing
