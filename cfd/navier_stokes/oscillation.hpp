// Forced pitch oscillation of the hovering insect: the pitch-rate and pitch-attitude derivatives at one frequency
// (docs/theory/cfd-stability.md, "Forced pitch oscillation").
//
// The body turns about O, theta(tau) = theta0 sin(omega tau), tau the time since the kept hover state,
// omega = 2 pi f / P (P wingbeats per oscillation period), with its wings flapping relative to it as in the hover.
// The grid turns with it (a frame at rate (0, q(tau), 0): SimulationOptions::frame_rotation), so the body keeps its
// cells. Its loads in body axes, minus the continued hover's at the same step, are averaged per wingbeat (d_k)
// and fitted, after the transient wingbeats, by least squares to
//     d_k = a theta_k + b q_k + c,
// theta_k, q_k the same wingbeat's means of theta and q = dtheta/dt at the load samples. b is the rate derivative
// (X_q, Z_q, M_q) and a the attitude derivative (X_theta, Z_theta, M_theta) at that frequency: the in-phase and
// quadrature parts of the response, the wind-tunnel forced-oscillation method (e.g. Etkin & Reid 1996, Dynamics of
// Flight, ch. 3; for insects in still air a steady attitude change does nothing, so a is the wake's lag). Unlike a
// steady rotation the body turns by theta0 at most, so the response holds a bounded attitude change relative to the
// wake, which a steady rate does not (docs/validation.md, "Steady pitch-rate runs").
#pragma once
#include <array>
#include <string>
#include <vector>
#include "core/types.hpp"

namespace flapstab::ns {

struct PitchOscillationSpec {
  double amplitude = 0;          // theta0 (rad), nose up first
  int period_wingbeats = 10;     // P: wingbeats per oscillation period (>= 3; at 2 the wingbeat means of q vanish)
  int transient_wingbeats = -1;  // wingbeats left out of the fit at the start (-1: P)
  int periods = 2;               // periods fitted after the transient
  int transient() const { return transient_wingbeats < 0 ? period_wingbeats : transient_wingbeats; }
  int wingbeats() const { return transient() + periods * period_wingbeats; }
};

// theta(tau), q(tau) = dtheta/dtau and dq/dtau for wingbeat period T (s).
struct PitchAngle {
  double theta = 0, rate = 0, rate_rate = 0;
};
PitchAngle pitch_oscillation_angle(const PitchOscillationSpec& spec, double T, double tau);

// Least-squares fit y_k = a x1_k + b x2_k + c with the standard errors of a and b from the residuals (-1 with fewer
// than 4 points); rms: the residuals' root mean square.
struct OscillationFit {
  double theta = 0, rate = 0, constant = 0;
  double theta_se = -1, rate_se = -1;
  double rms = 0;
};
OscillationFit fit_oscillation(const std::vector<double>& theta, const std::vector<double>& rate,
                               const std::vector<double>& y);

// One wingbeat of the run: means of theta (rad) and q (rad/s) at its load samples, and of the loads' difference from
// the continued hover (body axes, moment about O; N, N m); and that difference at each of its phase-locked steps
// (steps[i] at phase (i + 1) / n of the wingbeat, n steps per wingbeat; empty in a run kept by a flapstab that did
// not store them).
struct OscillationWingbeat {
  double theta = 0, rate = 0;
  Wrench difference;
  std::vector<Wrench> steps;
};

struct PitchOscillationResult {
  PitchOscillationSpec spec;
  double omega = 0;                  // rad/s
  std::vector<OscillationWingbeat> wingbeats;
  // Per load component (Fx Fy Fz Mx My Mz): the fit over every wingbeat after the transient, and over the last
  // period alone (the response's convergence: the two agree once it is periodic).
  std::array<OscillationFit, 6> fit, last_period;
  // The phase-resolved response: per phase-locked step i, the same fit of the steps' differences over the wingbeats
  // after the transient, d_k(i) = a(i) theta(t_ki) + b(i) q(t_ki) + c(i), with theta and q at the step's own time.
  // Empty when a fitted wingbeat has no steps; phase_note then says why.
  std::vector<std::array<OscillationFit, 6>> phase;
  std::string phase_note;
  double wall_seconds = 0;
  bool reused = false;
};

// The fits of a run's wingbeats (the fields above from spec, omega and wingbeats; wingbeats.size() >= transient + one
// period), the phase-resolved ones included.
void fit_pitch_oscillation(PitchOscillationResult& r);

}  // namespace flapstab::ns
