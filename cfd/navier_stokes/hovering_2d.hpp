// The two-dimensional hovering wing of Wang, Birch & Dickinson 2004 (J Exp Biol 207:449-460): a flat elliptic
// wing translating back and forth along a horizontal line while it pitches, at Re = 75, started impulsively in
// fluid at rest. The one flapping-wing case with measured force histories (a dynamically scaled robotic wing) and
// independent CFD results (Eldredge 2007, J Comput Phys 221:626; Li, Dong & Liu 2015, J Fluids Struct 58:49) as
// plain numbers (data/reference/wbd2004-hovering-2d/). docs/validation.md, "2-D hovering wing".
//
// Case (non-dimensional: chord c = 1, density 1): an ellipse of thickness 0.1 c pitching about its centre,
//   x(t) = (A0 / 2) cos(2 pi f t),  A0 = 2.8 c, f = 0.25 (T = 4);
//   alpha(t) = pi/2 + beta sin(2 pi f t), beta = pi/4 (the chord's angle from the horizontal, counter-clockwise),
//   Re = U_max c / nu = 75 with U_max = pi A0 f.
// The wing starts from x = A0/2 with the chord vertical, moving towards -x (leading edge up in that half-stroke).
//
// A 2-D case in the 3-D solver: the plane of motion is x (horizontal) - y (vertical, up), z is a thin periodic
// slab of `span_cells` cells; the wing is the ellipse extruded along z as a closed surface reaching past both
// ends of the slab (its caps lie outside the domain). The default slab is two cells deep: the flow stays 2-D to
// the Poisson tolerance (Hovering2dResult::spanwise_deviation reports it). A one-cell slab, the exact 2-D
// reduction, diverges on the c/32 grid a few hundred steps in (an open defect of the immersed boundary's
// pressure extension there, docs/validation.md) and is refused. The box [-15, 15]^2 c
// has walls at rest; a uniform fine box (the region the wing sweeps, and the wake below it) with geometric
// stretching outside, as in PetIBM's example of this case (barbagroup/petibm-examples, flapping2dRe75).
//
// Loads per unit span: the momentum exchange of the forcing (ImmersedBoundary::exchange_loads, the primary
// estimate) divided by the slab's depth, and the probe-based surface integral divided by the extruded surface's
// length (its probes are clamped to the slab, where the flow does not depend on z). Lift = +y force; drag = the
// x force against the direction of translation. Coefficients are divided, as the published histories are, by
// the maxima over the cycle of the quasi-steady force (quasi_steady_maxima).
#pragma once
#include <array>
#include <functional>
#include <string>
#include <vector>
#include "core/types.hpp"

namespace flapstab::ns {

struct Hovering2dCase {
  // Case (chords, periods; the density is 1)
  double thickness = 0.1;          // of the chord
  double amplitude = 2.8;          // A0: stroke length, chords, peak to peak
  double frequency = 0.25;         // f (1/time unit; T = 1/f)
  double pitch_amplitude = pi / 4;  // beta, rad
  double reynolds = 75;            // U_max c / nu, U_max = pi A0 f
  double cycles = 4;               // run length, periods
  // Grid and numerics
  double cells_per_chord = 32;     // fine box spacing h = c / cells_per_chord
  double stretch_ratio = 1.05;     // largest ratio of neighbouring cell widths outside the fine box
  double half_width = 15;          // the box is [-half_width, half_width]^2, chords
  std::array<double, 2> box_x{-2, 2}, box_y{-3, 1};  // the uniform fine box, chords
  int span_cells = 2;              // depth of the periodic slab, cells of width h (at least 2)
  int outline_points = 256;        // vertices of the ellipse's outline (clustered at the edges)
  double cfl = 1.2;                // adaptive time step's CFL number (RK3, central fluxes: stable to sqrt 3)
  bool hypre = false;              // pressure solves by hypre (PCG + SMG): they converge on the elongated cells of large boxes

  double max_speed() const { return pi * amplitude * frequency; }  // U_max
  double viscosity() const { return max_speed() / reynolds; }      // nu (c = 1)
  double period() const { return 1 / frequency; }
  // Throws std::invalid_argument naming the field for a value out of range.
  void check() const;
};

// Kinematics of the wing's centre and chord at time t.
struct Hovering2dKinematics {
  double x = 0, u = 0, a = 0;              // centre position, velocity, acceleration (chords, per time unit)
  double alpha = 0, omega = 0, omega_dot = 0;  // chord angle from the horizontal (rad), its rates
  int direction = 0;                         // -1 in the first half-stroke (towards -x), +1 in the second
};
Hovering2dKinematics hovering_2d_kinematics(const Hovering2dCase& c, double t);

// The quasi-steady normalisation of the published histories (Wang et al. 2004; PetIBM's script of the case):
// at each chord point the local speed |v| of the rigid motion (translation plus rotation about the centre) and
// the coefficients C_L = 1.2 sin 2 alpha_e, C_D = 1.4 - cos 2 alpha_e of the chord angle folded with the
// direction of motion (alpha_e = alpha in the second half-stroke, pi - alpha in the first); L = 1/2 |v|^2 C_L c,
// D = 1/2 |v|^2 C_D c per unit span. The maxima over the chord points and over a cycle.
//
// The published reference curves do not say which rule they carry. Another convention is used with the same
// curves by barbagroup's cuIBM (its plotForceCoefficients.py for this case): 1/2 U_max^2 c times 1.2 (lift) and 1.4
// (drag), the quasi-steady force of the centre's translation alone at mid-stroke (alpha_e = 45 deg, no rotation):
// 4.2 % and 10.3 % below the chord-point maxima. Reported beside the first as `*_translational`; the tests and the
// figures use the first (the reference data's README, PetIBM's script).
struct QuasiSteadyMaxima {
  double lift = 0, drag = 0;  // per unit span (rho = 1, c = 1)
  double lift_translational = 0, drag_translational = 0;  // 1/2 U_max^2 c x 1.2 and x 1.4
  int chord_points = 0, time_samples = 0;
};
QuasiSteadyMaxima hovering_2d_quasi_steady_maxima(const Hovering2dCase& c, int chord_points = 101,
                                                  int samples_per_cycle = 20000);

// One step of the run.
struct Hovering2dSample {
  double t = 0, phase = 0;  // time, and t / T
  double x = 0, alpha = 0;  // the wing's centre and chord angle (rad)
  double lift = 0, drag = 0;                  // per unit span, momentum exchange
  double lift_surface = 0, drag_surface = 0;  // per unit span, surface integral
  double cl = 0, cd = 0;                      // lift / L_max, drag / D_max (momentum exchange)
  double cfl = 0;
};

struct Hovering2dResult {
  Hovering2dCase settings;
  QuasiSteadyMaxima normalisation;
  std::vector<Hovering2dSample> samples;
  int nx = 0, ny = 0, nz = 0;
  long steps = 0;
  double seconds = 0;
  // Departure from a 2-D flow at the end: the largest spanwise velocity |w| and spanwise variation of u and v,
  // relative to U_max (zero to rounding for a z-independent solution).
  double spanwise_deviation = 0;
  // Cycle means (trapezoid rule over cycle k = 1, 2, ...: [k-1, k] T) of C_L and C_D, momentum exchange and
  // surface integral; complete cycles only.
  std::vector<double> cycle_cl, cycle_cd, cycle_cl_surface, cycle_cd_surface;
};

// Runs the case; `progress` (if given) sees every step.
Hovering2dResult run_hovering_2d(const Hovering2dCase& c,
                                 const std::function<void(const Hovering2dSample&)>& progress = {});

// Mean of the series v(tau) over [k - 1, k] (trapezoid rule, the ends linearly interpolated); tau increasing.
// NaN when the series does not cover the interval.
double cycle_mean(const std::vector<double>& tau, const std::vector<double>& v, int k);

// A published history: two columns, t/T and the coefficient (data/reference/wbd2004-hovering-2d/*.dat).
struct CoefficientHistory {
  std::string label, file;
  std::vector<double> phase, value;
};
// InputError naming the file and line for anything but two numbers per line. The points are kept in the file's
// order (digitised curves hold a few points whose t/T goes back).
CoefficientHistory read_coefficient_history(const std::string& path, std::string label);
// The published rule for a history's mean over [from, to] (the reference data's README): the trapezoid rule over
// the points inside, in the file's order, divided by the span of their t/T.
double published_mean(const CoefficientHistory& h, double from, double to);

// A history compared with a reference over the cycles from + 1 .. to: the means are those of the cycle means
// (ours by cycle_mean, the reference's by published_mean); correlation and rms difference at the reference's
// points, ours interpolated there, leaving out the points within `reversal_gap` periods of a stroke reversal
// (drag changes sign there by definition, and a digitised jump a little early or late would dominate them).
struct HistoryComparison {
  double mean = 0, reference_mean = 0;
  double correlation = 0;
  double rms_difference = 0;
  int points = 0;
};
HistoryComparison compare_history(const std::vector<double>& phase, const std::vector<double>& value,
                                  const CoefficientHistory& reference, int from, int to, double reversal_gap = 0);

}  // namespace flapstab::ns
