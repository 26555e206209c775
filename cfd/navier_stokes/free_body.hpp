// A free rigid body carrying immersed parts through a grid fixed in space: its frame from the body state, the
// parts' kinematics in the grid from their motion relative to the body, the fluid's loads moved to the body, and
// the body's equations integrated across a time step with the loads held (the explicit coupling of free flight,
// docs/theory/fluid-body-coupling.md).
//
// Axes: the grid's axes are the inertial axes of the body state (core/eom.hpp: z down, gravity +z); at a zero
// state the body's axes coincide with them and O with the grid's origin.
#pragma once
#include <functional>
#include "cfd/navier_stokes/immersed.hpp"
#include "core/eom.hpp"

namespace flapstab::ns {

// The body's frame at one instant.
struct BodyFrame {
  Mat3 rotation = Mat3::Identity();  // body -> grid axes (3-2-1 Euler angles of the state)
  Vec3 origin = Vec3::Zero();        // O in the grid (m)
  Vec3 velocity = Vec3::Zero();      // of O, body axes (m/s): the state's u v w
  Vec3 rate = Vec3::Zero();          // body axes (rad/s): p q r
  Vec3 velocity_rate = Vec3::Zero();  // d(u v w)/dt (body-axes components, m/s^2)
  Vec3 rate_rate = Vec3::Zero();      // d(p q r)/dt (rad/s^2)
};
// The frame of state x whose time derivative is dx.
BodyFrame body_frame(const BodyStateVector& x, const BodyStateVector& dx);

// A part's kinematics in the grid from its kinematics relative to the body (body axes, the body at rest; e.g.
// Simulation::prescribed_parts): pose composed with the body's; velocity v + w x c + c'; acceleration of the
// material point v' + w x v + w' x c + w x (w x c) + 2 w x c' + c''; angular velocity w + w_rel and angular
// acceleration w' + w_rel' + w x w_rel, all rotated to the grid.
PartState part_in_grid(const BodyFrame& b, const PartState& relative);

// The wrench the fluid exerts, given in grid axes with its moment about the grid's origin, as the body's
// equations take it: body axes, moment about O.
Wrench wrench_on_body(const BodyFrame& b, const Vec3& force_grid, const Vec3& moment_grid_origin);

// The body's equations with the loads of the step's start held: dx/dt = rhs(t, x).
using BodyRhs = std::function<BodyStateVector(double t, const BodyStateVector& x)>;
// Classical Runge-Kutta from (t0, x0) to t in `substeps` equal steps (t < t0 allowed only as t = t0).
BodyStateVector integrate_body(const BodyRhs& rhs, double t0, const BodyStateVector& x0, double t, int substeps);
// The same for any state with vector arithmetic (an Eigen vector: the body state with more states beside it).
template <class State, class Rhs>
State runge_kutta(const Rhs& rhs, double t0, const State& x0, double t, int substeps) {
  if (t == t0 || substeps < 1) return x0;
  const double h = (t - t0) / substeps;
  State x = x0;
  for (int i = 0; i < substeps; ++i) {
    const double ti = t0 + i * h;
    const State k1 = rhs(ti, x);
    const State k2 = rhs(ti + h / 2, State(x + h / 2 * k1));
    const State k3 = rhs(ti + h / 2, State(x + h / 2 * k2));
    const State k4 = rhs(ti + h, State(x + h * k3));
    x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return x;
}

}  // namespace flapstab::ns
