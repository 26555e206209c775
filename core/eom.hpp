// Equations of motion of the rigid body with two wings in prescribed flapping motion relative to it.
//
// Newton-Euler for the whole system about the body-fixed reference point O (the wingbeat-mean CoM),
// in body (stability) axes rotating with angular velocity w:
//   dP/dt|_B + w x P = F,            P = m v + w x c + c',
//   dH/dt|_B + w x H + v x P = M_O,  H = c x v + J w + h_rel,
// with c = sum m_i r_i (first mass moment about O), J the inertia of all parts about O, and
// h_rel = sum (m_i r_i x r_i' + I_i w_i) the angular momentum of the wings' motion relative to the body.
// The wings' inertial forces and moments (their mass is ~6 % of a hawkmoth's) enter through c(t),
// J(t), h_rel(t) and their rates. Gravity is +z in the inertial frame (z down).
// State x = [x y z | u v w | p q r | phi theta psi]: position of O (inertial, m), velocity of O
// (body axes, m/s), body rates (rad/s), 3-2-1 Euler angles (rad).
#pragma once
#include <optional>
#include "core/configuration.hpp"

namespace flapstab {

using BodyStateVector = Eigen::Matrix<double, 12, 1>;

struct EomTerms {
  Eigen::Matrix<double, 6, 6> mass_matrix;  // multiplies [v'; w']
  Eigen::Matrix<double, 6, 1> rhs;          // generalised force minus inertial terms
};

// Mass matrix and right-hand side at time t for the given state and aerodynamic wrench about O
// (body axes). g is gravitational acceleration (m/s^2).
EomTerms eom_terms(const MassState& m, const BodyStateVector& x, const Wrench& aero, double g);

// dx/dt at time t. g defaults to the insect's gravity (config.insect().gravity).
BodyStateVector body_state_derivative(const Configuration& config, double t, const BodyStateVector& x,
                                      const Wrench& aero, std::optional<double> g = std::nullopt);

// d(body_state_derivative) / dx (12 x 12) at time t, the aerodynamic wrench responding to the body velocity
// and rates as aero_jacobian = d[F; M] / d[u v w p q r] (SI). Exact (forward-mode automatic differentiation of
// the equations above); the wrench's value does not enter, the equations being linear in it.
Eigen::Matrix<double, 12, 12> body_state_jacobian(const Configuration& config, double t, const BodyStateVector& x,
                                                  const Eigen::Matrix<double, 6, 6>& aero_jacobian,
                                                  std::optional<double> g = std::nullopt);

// Linear momentum (inertial axes) and angular momentum about the inertial origin (inertial axes)
// of the whole system: conserved without external loads (used by tests).
void system_momenta(const Configuration& config, double t, const BodyStateVector& x, Vec3& P_inertial,
                    Vec3& H_inertial);

}  // namespace flapstab
