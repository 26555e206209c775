// Nonlinear free flight: the body state advanced with instantaneous loads and (optionally) delayed feedback.
//
// Integrator: Dormand-Prince 5(4) with step-size control (Dormand & Prince 1980, J Comput Appl Math 6:19;
// Hairer, Norsett & Wanner, Solving ODEs I, II.4-5), error weights rtol |y| + rtol * scale (scale: c for
// positions, U for velocities, U/c for rates, 1 rad for angles). With feedback delays the step never exceeds
// the shortest latency, so every delayed argument lies in the accepted history (method of steps; the delay line
// interpolates it with cubic Hermite polynomials). Steps land on every wingbeat boundary, where a
// sample-and-hold controller updates its command. Before t = 0 the sensors see the unperturbed periodic orbit.
#pragma once
#include <algorithm>
#include <functional>
#include <string>
#include <vector>
#include "core/derivative_table.hpp"
#include "flight/controller.hpp"
#include "flight/dynamics.hpp"

namespace flapstab {

struct FlightOptions {
  double wingbeats = 10;          // duration in trimmed wingbeats
  int samples_per_wingbeat = 40;  // output samples (phase-locked)
  double rtol = 1e-9;
  double max_pitch_deg = 80;      // stop when |theta| or |phi| exceeds this (the 3-2-1 angles' singularity)
  // Progress callback after each wingbeat (wingbeat index, wingbeats): may be empty.
  std::function<void(int, int)> progress;
};

struct FlightSample {
  double t = 0;             // s
  BodyStateVector x;        // [x y z u v w p q r phi theta psi], SI
  Wrench aero;              // aerodynamic wrench about O, body axes
  double power = 0;         // aerodynamic power, W
  std::vector<double> command;  // actuator offsets from trim (parameter units)
};

struct FlightResult {
  std::vector<FlightSample> samples;  // t = k T / samples_per_wingbeat
  bool completed = true;              // false when the attitude left the envelope (stop_reason says which)
  std::string stop_reason;
  long steps = 0, rejected = 0, rhs_evaluations = 0;
  double wall_time_s = 0;
};

// Reference used by the sensors: the unperturbed periodic orbit as a function of time (periodic), and its
// cycle means (the hover reference the controller holds).
struct ReferenceOrbit {
  std::function<BodyStateVector(double)> state;  // x_ref(t)
  BodyStateVector mean = BodyStateVector::Zero();
};
// The orbit from samples at t_k = k T / N (k = 0..N-1, periodic) with periodic cubic splines; position drift is
// removed (x, y, z of the orbit are taken periodic).
ReferenceOrbit reference_orbit(const std::vector<BodyStateVector>& samples, double period);

// A controller bound to the dynamics' actuators (the quasi-steady and the coupled free flight share it): each term's
// sensed state and actuator index, its filter slot, and each actuator's offset limits from trim (parameter units).
// Throws SolveError for an actuator the dynamics do not have.
struct BoundController {
  struct Term {
    int state = 0, actuator = 0, filter = -1;
    FeedbackTerm spec;
  };
  std::vector<Term> terms;
  int filters = 0;
  std::vector<double> lower, upper;
  BoundController(const FlightDynamics& dyn, const ControllerSpec& c);
  // The command: -sum of gain x signal(term) per actuator, clamped to its limits.
  template <class Signal>
  std::vector<double> law(Signal&& signal) const {
    std::vector<double> u(lower.size(), 0.0);
    if (terms.empty()) return u;
    for (const Term& t : terms) u[std::size_t(t.actuator)] -= t.spec.gain * signal(t);
    for (std::size_t i = 0; i < u.size(); ++i) u[i] = std::clamp(u[i], lower[i], upper[i]);
    return u;
  }
};

// Integrates from x0 at t = 0 (its components that the DoF set holds are zeroed) with the controller (may be empty). Throws SolveError for a non-finite state.
FlightResult simulate_flight(const FlightDynamics& dynamics, const ControllerSpec& controller, const BodyStateVector& x0,
                             const ReferenceOrbit& reference, const ReferenceQuantities& ref,
                             const FlightOptions& options);

// Growth of the deviation from the reference orbit: per wingbeat k, the largest non-dimensional max-norm of
// x - x_ref over the states (velocities / U, rates c / U, angles rad); the rate is the least-squares slope of
// log(deviation) over wingbeats [first, last] (per wingbeat; > 0 grows).
// The same from the wingbeat means: per wingbeat the largest non-dimensional |mean of x_i - x_ref,i| over the
// states (the slow motion a controller acts on, without the within-wingbeat rocking that changed kinematics alter),
// and the slope of its logarithm over the same wingbeats.
struct GrowthEstimate {
  std::vector<double> deviation;  // per wingbeat
  double per_wingbeat = 0;
  int first = 0, last = 0;
  std::vector<double> mean_deviation;  // per wingbeat, from the wingbeat means
  double mean_per_wingbeat = 0;
};
GrowthEstimate wingbeat_growth(const FlightResult& r, const ReferenceOrbit& reference, const ReferenceQuantities& ref,
                               double period, const std::vector<int>& states, int first_wingbeat = -1);

}  // namespace flapstab
