// Feedback laws: the pitch controller as state-feedback terms, and their validation.
#include "flight/controller.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include "core/body_state.hpp"
#include "core/errors.hpp"
#include "trim/parameters.hpp"

namespace flapstab {

double ControllerSpec::max_latency() const {
  double m = 0;
  for (const auto& t : terms) m = std::max(m, t.latency_s);
  return m;
}

double ControllerSpec::min_positive_latency() const {
  double m = 0;
  for (const auto& t : terms)
    if (t.latency_s > 0) m = m == 0 ? t.latency_s : std::min(m, t.latency_s);
  return m;
}

ControllerSpec pitch_controller(const PitchControllerSettings& s, double trim) {
  ControllerSpec c;
  c.description = fmt::format("pitch feedback on {}: {} deg/deg of pitch after {} ms, {} deg per deg/s of pitch rate "
                              "after {} ms{}, |command| <= {}",
                              s.actuator, s.pitch_gain, s.pitch_latency_s * 1e3, s.rate_gain_s, s.rate_latency_s * 1e3,
                              s.filter_time_s > 0 ? fmt::format(", sensor filter {} ms", s.filter_time_s * 1e3) : "",
                              s.limit_deg);
  TrimParameterSpec a;
  a.name = s.actuator;
  a.lower = trim - s.limit_deg;
  a.upper = trim + s.limit_deg;
  c.actuators.push_back(a);
  constexpr double per_rad = 180 / 3.14159265358979323846;  // deg per rad: the gains are per degree
  c.terms.push_back({"theta", s.actuator, s.pitch_gain * per_rad, s.pitch_latency_s, s.filter_time_s});
  c.terms.push_back({"q", s.actuator, s.rate_gain_s * per_rad, s.rate_latency_s, s.filter_time_s});
  c.update = s.update;
  return c;
}

PitchControllerSettings pitch_controller_settings(const ControlSettings& c) {
  PitchControllerSettings s;
  s.actuator = c.actuator;
  s.pitch_gain = c.pitch_gain;
  s.rate_gain_s = c.rate_gain_s;
  s.pitch_latency_s = c.pitch_latency_s;
  s.rate_latency_s = c.rate_latency_s;
  s.filter_time_s = c.filter_time_s;
  s.limit_deg = c.limit_deg;
  s.update = c.update == "wingbeat" ? ControlUpdate::wingbeat : ControlUpdate::continuous;
  return s;
}

TrimParameterSpec unbounded_parameter(const std::string& name) {
  TrimParameterSpec s;
  s.name = name;
  s.lower = -1e9;
  s.upper = 1e9;
  return s;
}

double parameter_value(const Kinematics& kin, const std::string& name, const std::string& file) {
  return TrimParameterization(kin, {unbounded_parameter(name)}, file).initial()[0];
}

void validate_controller(const ControllerSpec& c, const std::string& file, const std::string& key) {
  for (std::size_t i = 0; i < c.terms.size(); ++i) {
    const FeedbackTerm& t = c.terms[i];
    const std::string k = fmt::format("{}[{}]", key, i);
    if (!body_state_index(t.state))
      throw InputError(file, k + ".state", "unknown state \"" + t.state + "\"",
                       "one of x y z u v w p q r phi theta psi");
    if (std::none_of(c.actuators.begin(), c.actuators.end(), [&](const auto& a) { return a.label() == t.actuator; }))
      throw InputError(file, k + ".actuator", "unknown actuator \"" + t.actuator + "\"",
                       "a kinematic parameter named in the controller's actuators");
    if (!std::isfinite(t.gain)) throw InputError(file, k + ".gain", "is not finite", "a finite gain");
    if (!(t.latency_s >= 0) || !std::isfinite(t.latency_s))
      throw InputError(file, k + ".latency_s", fmt::format("must be a non-negative finite delay, got {}", t.latency_s),
                       "a latency >= 0 s");
    if (!(t.filter_time_s >= 0) || !std::isfinite(t.filter_time_s))
      throw InputError(file, k + ".filter_time_s", fmt::format("must be non-negative, got {}", t.filter_time_s),
                       "a time constant >= 0 s");
  }
}

}  // namespace flapstab
