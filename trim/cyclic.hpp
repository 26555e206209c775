// Cyclic (periodic) hover trim by shooting: the initial body state and kinematic parameters for which
// the free body-plus-wings system returns to its initial state after one wingbeat with zero mean drift.
//
// The free system is core/eom.hpp's Newton-Euler equations with the model's instantaneous loads, the
// body velocity and rates fed to the aerodynamic model at every instant. For a symmetric insect the
// longitudinal subsystem is solved (v, p, r, phi, psi, y stay zero by symmetry; checked on the orbit):
// unknowns z = [u0, w0, q0, theta0, kinematic parameters of [trim]], equations
//   u(T) = u0, w(T) = w0, q(T) = q0, theta(T) = theta0   (periodicity)
//   x(T) = x(0), z(T) = z(0)                              (no drift over a wingbeat)
//   (1/T) int_0^T theta dt = 0                            (stability axes = the mean attitude)
// square for three parameters. With [trim] cyclic_attitude = "free" the last equation is left out: body_angle_deg
// (which must be a [trim] parameter, for the averaged trim's moment balance) is held at the averaged trim's
// value, the orbit settles at its own mean pitch, and the mean attitude (body angle + mean theta) is reported;
// square for the two other parameters. Newton (least squares / minimum norm otherwise) with the state columns
// of the Jacobian from CVODES forward sensitivities and the parameter columns from central differences
// of the period map, started from the averaged trim. Residuals are scaled: velocities / U, rates c / U,
// angles in rad, positions / c. Wu & Sun 2012 (J R Soc Interface 9:2033) find this cyclic equilibrium
// for the hawkmoth the same way; docs/theory/floquet.md.
#pragma once
#include <string>
#include <vector>
#include "cfd/phase_derivatives.hpp"
#include "core/case_file.hpp"
#include "trim/trim.hpp"

namespace flapstab {

struct CyclicTrimOptions {
  double tolerance = 1e-10;  // on the max-norm of the scaled residual
  int max_iterations = 30;
  double rtol = 1e-12;       // CVODES relative tolerance of the period map
  int amplitude_samples = 256;  // phases sampled for the within-cycle oscillation
};

struct CyclicTrimResult {
  bool converged = false;
  int iterations = 0, integrations = 0;
  double residual = 0;                         // max |scaled residual|
  std::vector<std::string> residual_names;     // u, w, q, theta, x_drift, z_drift, mean_theta (imposed attitude)
  Eigen::VectorXd residuals;                   // scaled
  std::vector<TrimParameterValue> parameters;  // initial = the averaged trim's value
  Kinematics kinematics;                       // with the cyclic-trim parameters
  double period = 0;                           // s
  BodyStateVector initial_state = BodyStateVector::Zero();  // at t = 0 (start of the downstroke)
  double mean_theta = 0;                       // rad (zero at convergence with the attitude imposed)
  bool free_attitude = false;                  // [trim] cyclic_attitude = "free"
  // The orbit's wingbeat-mean attitude: the body's long axis above the horizontal, body_angle + mean_theta (rad).
  double mean_body_angle = 0;
  // Within-cycle oscillation of [u, w, q, theta]: half peak-to-peak (SI: m/s, rad/s, rad) and non-dimensional.
  Eigen::Vector4d amplitude_si = Eigen::Vector4d::Zero(), amplitude_nd = Eigen::Vector4d::Zero();
  Eigen::Vector4d mean_si = Eigen::Vector4d::Zero();  // cycle means of [u, w, q, theta]
  // Largest |v|/U, |p| c/U, |r| c/U, |phi|, |psi|, |y|/c over the cycle: zero by symmetry.
  double symmetry_residual = 0;
  // d x(T) / d x(0) for [u v w p q r phi theta] about the converged orbit (CVODES sensitivities):
  // the monodromy matrix of the linearised free system, dimensional (route 2 of docs/theory/floquet.md).
  Eigen::Matrix<double, 8, 8> monodromy = Eigen::Matrix<double, 8, 8>::Zero();
  std::string message;
};

// Throws InputError unless the case is symmetric (kinematics and parameters) and the model has
// instantaneous loads: what cyclic_trim needs, checked before any work.
void check_cyclic_trim_case(const Case& c, const AeroModel& model);

// Solves the cyclic trim from the averaged trim's parameters. Throws InputError for an asymmetric case
// or a model without instantaneous loads; returns converged = false when Newton fails.
CyclicTrimResult cyclic_trim(const Case& c, const AeroModel& model, const TrimResult& averaged,
                             const CyclicTrimOptions& options = {});

// The orbit from x0 sampled at t_k = k T / N, k = 0..N-1 (CVODES at rtol).
std::vector<BodyStateVector> periodic_orbit(const InstantaneousAero& aero, const BodyStateVector& x0, int N,
                                            double rtol = 1e-12);

}  // namespace flapstab
