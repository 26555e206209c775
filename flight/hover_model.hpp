// The linear models of the hover that flight control is analysed on, computed once: averaged and cyclic trim,
// the periodic orbit, cycle-averaged stability and control derivatives, phase-resolved derivatives and the
// open-loop Floquet monodromy (the cyclic trim's flow sensitivity).
#pragma once
#include <vector>
#include "cfd/derivatives.hpp"
#include "cfd/phase_derivatives.hpp"
#include "flight/control_analysis.hpp"
#include "flight/control_derivatives.hpp"
#include "trim/cyclic.hpp"

namespace flapstab {

struct HoverModel {
  TrimResult averaged_trim;
  CyclicTrimResult cyclic;                 // the periodic hover orbit and its monodromy
  std::vector<BodyStateVector> orbit;      // at t_k = k T / N
  DerivativeResult derivatives;            // about the cyclic trim's kinematics, with control columns
  ControlDerivativeResult control;
  PhaseDerivatives phase;
  LinearPlant longitudinal, lateral;       // averaged, SI, with B for the actuators
  double wall_time_s = 0;
};

// For a symmetric case with an instantaneous model. Throws InputError / SolveError as floquet analysis does.
// `averaged`: the case's averaged trim when the caller has it already (analyze), else it is solved here.
HoverModel hover_model(const Case& c, const AeroModel& model, const std::vector<TrimParameterSpec>& actuators,
                       int phases = 0, const CyclicTrimOptions& cyclic = {}, const TrimResult* averaged = nullptr);

// The most unstable Floquet mode of the [u w q theta] ("longitudinal") or [v p r phi] ("lateral") subsystem as a
// BodyStateVector perturbation (real part of the eigenvector), scaled to non-dimensional max-norm `amplitude`.
BodyStateVector floquet_mode_perturbation(const HoverModel& h, const std::string& subsystem, double amplitude,
                                          std::complex<double>* multiplier = nullptr);

// The case's pitch controller ([control] type = "pitch") about an already computed hover: closed-loop stability of
// the averaged and periodic longitudinal loops, its critical latency (both signals delayed alike, the case's gains)
// and the best pitch gain with the case's rate gain. `derivatives` are about the cyclic trim's kinematics.
struct ControlSummary {
  std::string description;
  double period = 0;
  double open_abscissa = 0, closed_abscissa = 0;  // averaged longitudinal, 1/s
  double open_radius = 0, closed_radius = 0;      // periodic longitudinal spectral radius
  CriticalLatency critical, best;                 // latency in s
  double latency_max = 0;                         // the scanned range (s)
  ControlDerivativeResult control;
  NeutralAxis neutral;
};
ControlSummary pitch_control_summary(const Case& c, const AeroModel& model, const CyclicTrimResult& cyclic,
                                     const DerivativeResult& derivatives, const PhaseDerivatives& phase);

// The seed's neutral-axis argument tested: the centre of mass moved by dz (m, +down in stability axes) relative to
// the wing hinges, the hover re-trimmed, and the largest open-loop longitudinal growth per wingbeat from the averaged
// model, the Floquet monodromy and nonlinear free flight (0.5 deg of pitch, `wingbeats`), beside where the neutral
// axis then lies. The cyclic trims of the sweep converge to 1e-8 (scaled periodicity residual) instead of 1e-10:
// some moved insects stall just above 1e-10 in the line search, and 1e-8 leaves the growth rates unchanged to the
// printed digits.
struct ComSweepPoint {
  double dz = 0;                      // m
  double com_below_axis_m = 0;        // distance of the CoM below the neutral axis
  double lti_growth = 0, floquet_growth = 0;  // per wingbeat (> 0 unstable)
  double simulated_growth = 0;  // per wingbeat; +infinity: the flight left the attitude envelope; NaN: too short to fit
  bool lti_oscillatory = false;
};
std::vector<ComSweepPoint> com_height_sweep(const Case& c, const AeroModel& model, const std::vector<double>& dz,
                                            double wingbeats = 12);

}  // namespace flapstab
