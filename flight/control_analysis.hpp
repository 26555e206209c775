// Linear analyses of the hover under delayed feedback: the averaged plant (LTI with control derivatives) and the
// time-periodic plant (A(t), B(t) along the periodic orbit) closed by a ControllerSpec, the (gain, latency) map,
// and the neutral axis. Delay-exact: stability/delayed_feedback.hpp; theory in docs/theory/flight-control.md.
#pragma once
#include <optional>
#include <string>
#include <vector>
#include "cfd/phase_derivatives.hpp"
#include "flight/controller.hpp"
#include "flight/dynamics.hpp"
#include "stability/delayed_feedback.hpp"
#include "stability/lti.hpp"

namespace flapstab {

// x' = A x + B delta in SI (time in s; states m/s, rad/s, rad; inputs in parameter units).
struct LinearPlant {
  std::string name;
  std::vector<std::string> states;  // e.g. {"u", "w", "q", "theta"}
  std::vector<std::string> inputs;  // e.g. {"stroke_plane_deg"}
  Eigen::MatrixXd A, B;
};
// The averaged plant from a non-dimensional state space (stability/lti.hpp) and the table's reference.
LinearPlant averaged_plant(const StateSpace& nd, const ReferenceQuantities& ref);

// The closed loop x' = (A + filters) x + sum B_j x(t - tau_j) of a plant and a controller; with sensor filters
// the state is augmented by one filter state per filtered term (after the plant's states). Throws InputError
// (file, key) when a term senses a state the plant lacks or drives an input it has not.
DelaySystem closed_loop(const LinearPlant& plant, const ControllerSpec& controller, const std::string& file = "",
                        const std::string& key = "control");

// Time-periodic plant sampled at t_k = k T / N: A(t_k) from the phase-resolved derivatives and B(t_k) by central
// differences of the free system's right-hand side in each actuator (0.5 deg or 0.5 % of the frequency).
struct PeriodicPlant {
  std::string name;
  double period = 0;
  std::vector<std::string> states, inputs;
  std::vector<Eigen::MatrixXd> A, B;
};
PeriodicPlant periodic_plant(const FlightDynamics& dynamics, const PhaseDerivatives& phase,
                             const std::vector<std::string>& states);
PeriodicDelaySystem closed_loop(const PeriodicPlant& plant, const ControllerSpec& controller,
                                const std::string& file = "", const std::string& key = "control");

// The pitch controller's map: which gain the map's first axis scales, the other held at the case's value;
// the map's latency is given to both signals.
enum class MapGain { pitch, rate };
ControllerSpec controller_at(const PitchControllerSettings& base, MapGain which, double gain, double latency,
                             double actuator_trim);

// Neutral axis (longitudinal): the reference points P = (x, z) (m, from O in stability axes) about which a
// horizontal velocity gives no mean pitching moment, dM_P/du = M_u - (z X_u - x Z_u) = 0 (dimensional).
struct NeutralAxis {
  double z_at_com = 0;   // z of the axis on the vertical through O (m; negative = above the CoM)
  double slope = 0;      // dz/dx along the axis (Z_u / X_u)
  double com_below_axis_m = 0;  // distance of the CoM (O) below the axis along z (= -z_at_com)
  double Mu = 0, Xu = 0, Zu = 0;  // the dimensional derivatives used (N m s/m, N s/m)
};
NeutralAxis neutral_axis(const DerivativeTable& table);

}  // namespace flapstab
