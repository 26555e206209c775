// Stability from the Navier-Stokes model ([aero] model = "cfd"): the quasi-steady trim as the start, the CFD trim
// (Broyden on the CFD cycle means), the CFD derivative table and its phase-resolved A(t) from the same runs, and the
// Floquet analysis of that A(t); every run from one kept periodic hover state (cfd/navier_stokes/cfd_model.hpp),
// resumable from the run cache. Theory and limits: docs/theory/cfd-stability.md.
#pragma once
#include <array>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
#include "cfd/derivatives.hpp"
#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "stability/floquet.hpp"
#include "stability/modes.hpp"
#include "trim/trim.hpp"

namespace flapstab {

// One CFD velocity derivative split by mechanism ([aero.cfd.fpm]): the central differences of the partition's window
// means between the column's two runs, non-dimensional like the table. total: the table's value (the run's loads,
// pressure and skin friction, every step); pressure: the pressure load on the partition's body (its cut cells, or the
// forced region) that the parts should sum to; run_pressure,
// friction: the run's own pressure and skin-friction loads at the partition's samples.
struct MechanismSplit {
  int row = 0, column = 0;  // 0 .. 5: X Y Z L M N; u v w
  double total = 0, pressure = 0, kinematic = 0, centripetal = 0, vortex = 0, viscous = 0, outer = 0;
  double run_pressure = 0, friction = 0;
  double pressure_forced = 0;  // the share of pressure on the faces the immersed boundary forces
  double added_mass() const { return kinematic - centripetal; }
  double sum() const { return kinematic + vortex + viscous + outer; }
};
// The study's first stage and its checks before any CFD run: the quasi-steady trim of the case's [trim] parameters
// (`qs_model` is the case's quasi-steady model) and its derivatives, and the check that every derivative step moves
// the loads by at least 10 x perturbation_tolerance (InputError naming derivatives.relative_step or
// relative_rate_step, with the step that would do); SolveError when the trim does not converge.
void quasi_steady_start(const Case& c, const AeroModel& qs_model, TrimResult& trim, DerivativeResult& derivatives);

// The split of every velocity column of `columns` whose two runs were partitioned, for the load components they
// were partitioned in (rate columns: none, their grid turns).
std::vector<MechanismSplit> split_by_mechanism(const DerivativeResult& d, const std::vector<ns::CfdRunRecord>& runs,
                                               const std::vector<int>& columns);

// [derivatives.pitch_oscillation]: the forced pitch oscillation's fits (cfd/navier_stokes/oscillation.hpp),
// non-dimensional as the table (rows 0 .. 5 = X Y Z L M N): the rate derivative per q+ = q c / U and the attitude
// derivative per rad, with their standard errors (-1: none) and the last period's fit alone; and the longitudinal
// modes of the table with its q column replaced by the oscillation's and its aerodynamic theta column added.
struct PitchOscillationStudy {
  ns::PitchOscillationResult run;
  double omega_nd = 0;  // omega c / U
  std::array<double, 6> rate_nd{}, rate_se_nd{}, rate_last_nd{}, theta_nd{}, theta_se_nd{}, theta_last_nd{};
  std::optional<StabilityAnalysis> modes, modes_steady_rate;  // with the oscillation's columns; the table as it is
  // From the phase-resolved fits (ns::PitchOscillationResult::phase): the cycle means of the per-phase rate and
  // attitude derivatives (non-dimensional; beside the wingbeat fits above), and the Floquet analysis of the CFD A(t)
  // with its q column's X Z M rows replaced by the per-phase rate fits and the per-phase attitude fits added
  // (cfd_study; floquet_note says why there is none).
  std::optional<std::array<double, 6>> rate_phase_mean_nd, theta_phase_mean_nd;
  std::optional<FloquetAnalysis> floquet;
  std::string floquet_note;
};
// The non-dimensional fits and both mode sets from a finished oscillation and the CFD table (longitudinal columns).
PitchOscillationStudy pitch_oscillation_study(const ns::PitchOscillationResult& run, const DerivativeTable& table);

struct CfdStudy {
  TrimResult qs_trim;            // quasi-steady trim of the case's [trim] parameters: the starting point
  DerivativeResult qs_at_start;  // quasi-steady derivatives at the quasi-steady trim (resolution check)
  TrimResult trim;               // the CFD trim
  DerivativeResult qs;           // quasi-steady derivatives at the CFD trim's kinematics (the comparison)
  DerivativeResult derivatives;  // CFD cycle-averaged derivatives at the CFD trim
  PhaseDerivatives phase;        // CFD phase-resolved derivatives, from the same runs
  std::vector<MechanismSplit> by_mechanism;  // with [aero.cfd.fpm]: the velocity derivatives split by mechanism
  std::optional<FloquetAnalysis> floquet_longitudinal, floquet_lateral;
  std::optional<PitchOscillationStudy> pitch_oscillation;  // with [derivatives.pitch_oscillation]
  WrenchHistory history;         // CFD loads over the trimmed wingbeat
  std::vector<ns::CfdRunRecord> runs;
  std::vector<ns::CycleRecord> reference;  // the continued hover's cycle means
  ns::CfdPlan plan;
  std::size_t cells = 0;
  double seconds_per_step_estimate = 0;
  struct Stage {
    std::string name;
    double seconds = 0;
    int runs = 0;
  };
  std::vector<Stage> stages;
  double wall_time_s = 0;
  std::vector<std::string> notices;
};

// The whole chain. `cache_directory` keeps the states and finished runs ("" = none: nothing resumable). Prints the
// plan (runs, wingbeats, cells, estimated time) and progress on `log`. InputError before any CFD run for a
// derivative step the periodic convergence cannot resolve (names derivatives.relative_step, with the numbers).
// `ranks`: every flow over these ranks (a group of an MPI job; CfdModel::run_over), the others' log null.
CfdStudy cfd_study(const Case& c, const std::string& cache_directory, std::ostream* log,
                   std::shared_ptr<const ns::Decomposition> ranks = {});

// The plan's warning for a rate step (rad/s) that turns the body more than 5 deg per wingbeat (none below): the
// turn per wingbeat, over max_cycles, and the relative_rate_step that gives 5 deg.
std::optional<std::string> rate_step_warning(const Case& c, double rate_step, double frequency_hz);

nlohmann::json cfd_study_json(const CfdStudy& s);
// Markdown section: grid, convergence, cost per stage, CFD and quasi-steady tables side by side, Floquet.
std::string cfd_study_markdown(const CfdStudy& s);

}  // namespace flapstab
