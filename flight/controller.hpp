// Feedback laws with sensory latency: linear state feedback from delayed (optionally filtered) measurements to
// kinematic parameters, applied continuously or sampled once per wingbeat and held.
//
// Each term senses one body state x_j (core/body_state.hpp names) after its latency tau, subtracts the hover
// reference x_j,ref (by default the trimmed periodic orbit at the sensed instant, so the loop acts on the
// deviations the linear analyses describe; or the orbit's cycle mean, so the wingbeat-frequency rocking of the
// body is fed back too), optionally low-pass filters it
// (T_f s' = x_j(t - tau) - x_j,ref - s), and adds -gain * s to its actuator's command:
//   delta p_a(t) = clamp(p_a,trim - sum_terms(a) gain * s, lower_a, upper_a) - p_a,trim.
// The seed's pitch controller is two such terms, on pitch angle theta and pitch rate q, acting on the relative
// pitch of the stroke plane and the body (Cheng, Deng & Hedrick 2011, J Exp Biol 214:4092; docs/theory/flight-control.md).
#pragma once
#include <string>
#include <vector>
#include "core/case_file.hpp"

namespace flapstab {

enum class ControlUpdate {
  continuous,  // the command follows the delayed measurements at every instant
  wingbeat,    // sampled at the start of each (trimmed) wingbeat and held for it
};

struct FeedbackTerm {
  std::string state;     // sensed body state: x y z u v w p q r phi theta psi
  std::string actuator;  // kinematic parameter (trim parameter name, e.g. "stroke_plane_deg")
  double gain = 0;       // actuator unit (deg or Hz) per SI unit of the state (m, m/s, rad/s, rad)
  double latency_s = 0;  // sensory-motor delay
  double filter_time_s = 0;  // first-order sensor filter time constant (0: none)
};

struct ControllerSpec {
  std::string description;
  // The actuated parameters with the absolute limits of each (parameter units): the actuator saturates there.
  std::vector<TrimParameterSpec> actuators;
  std::vector<FeedbackTerm> terms;
  ControlUpdate update = ControlUpdate::continuous;
  // true: x_j,ref(t) = the periodic orbit at the sensed instant; false: its cycle mean.
  bool sense_orbit_deviation = true;
  bool empty() const { return terms.empty(); }
  double max_latency() const;
  double min_positive_latency() const;  // 0 when no term has a latency
};

// The seed's pitch controller: delta p = -(pitch_gain theta_deg(t - tau_theta) + rate_gain_s q_deg_s(t - tau_q)).
struct PitchControllerSettings {
  std::string actuator = "stroke_plane_deg";
  double pitch_gain = 0;       // deg of actuator per deg of pitch angle
  double rate_gain_s = 0;      // deg of actuator per deg/s of pitch rate (s)
  double pitch_latency_s = 0;  // latency of the pitch-angle signal (visual)
  double rate_latency_s = 0;   // latency of the pitch-rate signal (mechanosensory)
  double filter_time_s = 0;    // first-order filter on both signals (0: none)
  double limit_deg = 30;       // |delta p| <= limit (actuator unit)
  ControlUpdate update = ControlUpdate::continuous;
};
ControllerSpec pitch_controller(const PitchControllerSettings& s, double actuator_trim_value);
// The [control] table's pitch-controller settings.
PitchControllerSettings pitch_controller_settings(const ControlSettings& c);

// A kinematic parameter without limits (an actuator whose range a controller sets, or one differentiated).
TrimParameterSpec unbounded_parameter(const std::string& name);
// The parameter's value in these kinematics (deg or Hz).
double parameter_value(const Kinematics& kin, const std::string& name, const std::string& file = "");

// Checks names, signs and finiteness; InputError naming file and key ("control...").
void validate_controller(const ControllerSpec& c, const std::string& file, const std::string& key);

}  // namespace flapstab
