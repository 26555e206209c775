// The translation-only model ([body_motion] model = "translation-only"): the body's attitude is prescribed - the
// trimmed attitude (stability axes S) turned by periodic 3-2-1 Euler angles (roll, pitch, yaw series of the wingbeat
// phase) - while its position and velocity are free. Its equations are the force equations of core/eom.hpp with the
// prescribed body rates w(t) and their rates w'(t) in every inertial term (w x P, w' x c, w x c') and in the
// aerodynamic model's body motion (so in the blade velocities), and gravity along the prescribed attitude:
//   m v' = F_aero(t, v, w(t)) + m g_B(t) - w x P - w' x c - w x c' - sum m_i r_i'',   P = m v + w x c + c',
//   x'   = R(t) v,   R = euler321(phi(t), theta(t), psi(t)).
// The moment equation is dropped: whatever moment the prescribed attitude needs is supplied from outside (the model of
// an insect whose attitude is held or driven, or of a tethered one free to translate).
//
// Its cyclic trim finds the initial velocity [u0, v0, w0] and the kinematic parameters named in
// [body_motion] trim_parameters such that the velocity is periodic and the position does not drift over a wingbeat:
//   [u v w](T) = [u v w](0),  [x y z](T) = [x y z](0)
// (six equations; for a symmetric insect v and y vanish identically and two parameters, for X and Z, make the
// system square). Newton as the free cyclic trim (trim/cyclic.hpp), from the averaged trim's kinematics. Its
// monodromy d[u v w](T)/d[u v w](0) (CVODES sensitivities) gives the Floquet exponents of [u, v, w].
#pragma once
#include <string>
#include <vector>
#include "cfd/phase_derivatives.hpp"
#include "core/case_file.hpp"
#include "trim/cyclic.hpp"

namespace flapstab {

// The prescribed attitude at time t: Euler angles relative to the trimmed attitude (rad), body rates (body axes,
// rad/s) and their time derivatives (rad/s^2).
struct PrescribedAttitude {
  double phi = 0, theta = 0, psi = 0;
  Vec3 rates = Vec3::Zero(), rates_dot = Vec3::Zero();
};
PrescribedAttitude prescribed_attitude(const BodyMotionSettings& b, double frequency_hz, double t);

using TranslationState = Eigen::Matrix<double, 6, 1>;  // [x y z | u v w]

// The 12-state body vector of a translation-only state at time t (attitude and rates prescribed).
BodyStateVector translation_body_state(const BodyMotionSettings& b, double frequency_hz, double t,
                                       const TranslationState& y);

// dy/dt of the translation-only model (the equations above). g defaults to the insect's gravity.
TranslationState translation_derivative(const InstantaneousAero& aero, const BodyMotionSettings& b, double t,
                                        const TranslationState& y, std::optional<double> g = std::nullopt);

struct TranslationTrimResult {
  bool converged = false;
  int iterations = 0, integrations = 0;
  double residual = 0;                          // max |scaled residual|
  std::vector<std::string> residual_names;      // u, v, w, x_drift, y_drift, z_drift
  Eigen::VectorXd residuals;                    // velocities / U, drifts / c
  std::vector<TrimParameterValue> parameters;   // initial = the starting kinematics' value
  Kinematics kinematics;
  double period = 0;
  Vec3 initial_velocity = Vec3::Zero();         // [u v w](0), m/s
  Vec3 mean_velocity = Vec3::Zero();            // cycle mean of [u v w], m/s
  Eigen::Matrix3d monodromy = Eigen::Matrix3d::Zero();  // d[u v w](T) / d[u v w](0)
  std::string message;
};

// Throws InputError unless the case has [body_motion] with model = "translation-only", the model has instantaneous
// loads and every name in trim_parameters is one of the case's [[trim.parameter]].
void check_translation_case(const Case& c, const AeroModel& model);

// The translation-only cyclic trim from the kinematics `start` (the averaged trim's): the [trim] parameters named in
// [body_motion] trim_parameters vary, the others stay at their values in `start`.
TranslationTrimResult translation_cyclic_trim(const Case& c, const AeroModel& model, const Kinematics& start,
                                              const CyclicTrimOptions& options = {});

}  // namespace flapstab
