// The insect's prescribed motion in the CFD grid: the wing kinematics composed with a steady body motion, as the
// kinematics values (pose, velocity, acceleration) the immersed boundary takes at each Runge-Kutta stage.
//
// The grid's axes are the hover stability axes S at the start of the motion, origin O. A steady body velocity V
// enters as the uniform stream -V through the far field (the insect does not translate in the grid); steady rates
// Omega turn the whole insect about O: body rotation B(t) = exp([Omega] (t - t_start)). The accelerations are
// analytic: a wing's angular acceleration is B w_dot + Omega x (B w) (w, w_dot relative to the body, from the
// kinematics), and points fixed in the body accelerate centripetally, Omega x (Omega x x).
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
  InsectMotion(const Configuration& config, const BodyMotion& motion, double t_start = 0)
      : config_(&config), motion_(motion), t_start_(t_start) {}
  const BodyMotion& body_motion() const { return motion_; }
  double start() const { return t_start_; }
  // B(t): the whole insect's rotation about O.
  RigidTransform body_rotation(double t) const;
  // Body, right wing, left wing in grid axes at time t.
  std::vector<PartState> parts(double t) const;
  // Each part's motion relative to the body, expressed in grid axes (centre, velocity and rates), for the wings'
  // work through their motion relative to the body.
  std::array<RigidVelocity, 3> relative(double t) const;

 private:
  const Configuration* config_;
  BodyMotion motion_;
  double t_start_;
};

}  // namespace flapstab::ns
