// Stability from the Navier-Stokes model ([aero] model = "cfd"): the quasi-steady trim as the start, the CFD trim
// (Broyden on the CFD cycle means), the CFD derivative table and its phase-resolved A(t) from the same runs, and the
// Floquet analysis of that A(t); every run from one kept periodic hover state (cfd/navier_stokes/cfd_model.hpp),
// resumable from the run cache. Theory and limits: docs/theory/cfd-stability.md.
#pragma once
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>
#include "cfd/derivatives.hpp"
#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "stability/floquet.hpp"
#include "trim/trim.hpp"

namespace flapstab {

struct CfdStudy {
  TrimResult qs_trim;            // quasi-steady trim of the case's [trim] parameters: the starting point
  DerivativeResult qs_at_start;  // quasi-steady derivatives at the quasi-steady trim (resolution check)
  TrimResult trim;               // the CFD trim
  DerivativeResult qs;           // quasi-steady derivatives at the CFD trim's kinematics (the comparison)
  DerivativeResult derivatives;  // CFD cycle-averaged derivatives at the CFD trim
  PhaseDerivatives phase;        // CFD phase-resolved derivatives, from the same runs
  std::optional<FloquetAnalysis> floquet_longitudinal, floquet_lateral;
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
CfdStudy cfd_study(const Case& c, const std::string& cache_directory, std::ostream* log);

// The plan's warning for a rate step (rad/s) that turns the body more than 5 deg per wingbeat (none below): the
// turn per wingbeat, over max_cycles, and the relative_rate_step that gives 5 deg.
std::optional<std::string> rate_step_warning(const Case& c, double rate_step, double frequency_hz);

nlohmann::json cfd_study_json(const CfdStudy& s);
// Markdown section: grid, convergence, cost per stage, CFD and quasi-steady tables side by side, Floquet.
std::string cfd_study_markdown(const CfdStudy& s);

}  // namespace flapstab
