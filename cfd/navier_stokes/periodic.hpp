// Periodic CFD runs: a Simulation advanced wingbeat by wingbeat until its cycle-mean loads stop changing.
//
// A run starts on a wingbeat boundary with a fixed, phase-locked step (steps_per_cycle > 0). After each wingbeat
// the cycle mean of the total wrench about O (the mean of the wingbeat's steps_per_cycle rows, the periodic
// trapezoid rule) is compared with the previous wingbeat's:
//     change = max(|dF| / F_s, |dM| / M_s),  F_s = weight, M_s = weight x mean chord,
// and the run is converged once change < tolerance after at least min_cycles wingbeats (max_cycles at most).
// If the cycle means approach their limit geometrically with ratio r per wingbeat, the remaining error is
// change r / (1 - r): below the change itself for r < 1/2 (docs/theory/cfd-stability.md).
#pragma once
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>
#include "cfd/navier_stokes/simulation.hpp"

namespace flapstab::ns {

struct PeriodicSettings {
  double tolerance = 0.005;  // cycle-to-cycle change, fraction of F_s (forces) and M_s (moments)
  int min_cycles = 2;        // wingbeats at least (2: a change needs two cycle means)
  int max_cycles = 12;       // wingbeats at most
  double force_scale = 1;    // F_s (N): the weight
  double moment_scale = 1;   // M_s (N m): weight x mean chord
};

struct CycleRecord {
  int cycle = 0;       // 1, 2, ... within the run
  Wrench mean;         // cycle mean of the total wrench (N, N m; about O, stability axes)
  double change = -1;  // relative change from the previous cycle (-1 for the first)
  // Perturbed runs (cfd_model.hpp): the change that the least-squares trend of the per-wingbeat mean difference makes
  // across the averaging window (window_statistics below: the larger of the force and moment vectors' changes) as a
  // fraction of the weight (moments: of weight x mean chord); -1 where not computed. A window whose mean has a small
  // standard error can still drift.
  double drift = -1;
};

struct PeriodicRun {
  std::vector<CycleRecord> cycles;
  bool converged = false;
  std::vector<CfdLoadRow> last_cycle;  // the last wingbeat's steps_per_cycle rows (phase-locked)
  double wall_seconds = 0;
  double final_change() const { return cycles.empty() ? -1 : cycles.back().change; }
};

// Relative change between two cycle means.
double cycle_change(const Wrench& a, const Wrench& b, const PeriodicSettings& s);

// The averaging window of a perturbed run (cfd_model.hpp): the mean of its wingbeat means, the standard error of that
// mean, and the change the least-squares trend of the wingbeat means makes across the window, both as fractions of
// the scales (the larger of force / force_scale and moment / moment_scale, vector norms); -1 with one wingbeat.
struct WindowStatistics {
  Wrench mean;
  double standard_error = -1, drift = -1;
};
WindowStatistics window_statistics(const std::vector<Wrench>& means, const PeriodicSettings& s);

// Advances `sim` wingbeat by wingbeat until converged (or max_cycles); a progress line per wingbeat on `log`
// starting with `label`. SolveError if the plan has no fixed step or the simulation is not on a wingbeat boundary;
// StepFailure if a step fails. A run killed part way continues from `earlier`, the wingbeats it had finished (with
// `sim` restored to its state after them): the result is that of the uninterrupted run. `after_wingbeat` is called
// with the run so far after every wingbeat that does not end it (to keep that state).
PeriodicRun run_until_periodic(Simulation& sim, const PeriodicSettings& s, std::ostream* log, const std::string& label,
                               PeriodicRun earlier = {},
                               const std::function<void(const PeriodicRun&)>& after_wingbeat = {});

}  // namespace flapstab::ns
