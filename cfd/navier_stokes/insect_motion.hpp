// The insect's prescribed motion in the CFD grid: the wing kinematics relative to the body, as the kinematics
// values (pose, velocity, acceleration) the immersed boundary takes at each Runge-Kutta stage.
//
// The grid is fixed to the body: its axes are the body's stability axes S, origin O. A steady body motion
// (velocity V, rates Omega; the u, v, w, p, q, r of the literature) is seen from that frame: the still air far away
// moves at -V - Omega x r, and with Omega != 0 the frame rotates, so the momentum equation carries the Coriolis
// acceleration and the pressure is the reduced one (SolverOptions::frame_rate). Body and wings then move in the
// grid only by the kinematics, over the same swept volume for every motion: one grid serves the hover and all its
// perturbations. Accelerations are analytic (the wings' w_dot from the kinematics); the parts' apparent
// accelerations add the Coriolis term 2 Omega x v (PartState::frame_rate).
#pragma once
#include <array>
#include <vector>
#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "core/aero_model.hpp"
#include "core/configuration.hpp"

namespace flapstab::ns {

class InsectMotion {
 public:
  // `config` must outlive this.
  InsectMotion(const Configuration& config, const BodyMotion& motion) : config_(&config), motion_(motion) {}
  const BodyMotion& body_motion() const { return motion_; }
  // Body, right wing, left wing (then the hind pair's right and left wing for a four-winged insect) in grid (= body)
  // axes at time t, velocities relative to the grid.
  std::vector<PartState> parts(double t) const;
  // Velocity of the still air far away, seen from the grid: -V - Omega x x.
  Vec3 far_field(const Vec3& x) const { return -motion_.velocity - motion_.rate.cross(x); }

 private:
  const Configuration* config_;
  BodyMotion motion_;
};

}  // namespace flapstab::ns
