// The `floquet` subcommand: cyclic trim, phase-resolved derivatives, monodromy by two routes, Floquet modes
// beside the averaged LTI modes (docs/theory/floquet.md).
#pragma once
#include <optional>
#include <nlohmann/json.hpp>
#include "apps/commands.hpp"
#include "cfd/derivatives.hpp"
#include "cfd/phase_derivatives.hpp"
#include "stability/analysis.hpp"
#include "stability/floquet.hpp"
#include "trim/cyclic.hpp"
#include "trim/trim.hpp"

namespace flapstab {

// Floquet results of one subsystem (longitudinal [u, w, q, theta] or lateral [v, p, r, phi]).
struct FloquetSubsystem {
  FloquetAnalysis phase_resolved;     // route 1: Phi' = A(t) Phi, A from the phase-resolved derivatives
  FloquetAnalysis flow_sensitivity;   // route 2: d x(T) / d x(0) of the nonlinear flow (CVODES)
  MonodromyResult integration;        // route 1's CVODE statistics
  double max_multiplier_difference = 0;  // max over multipliers of |mu_1 - mu_2| (both sorted alike)
  bool has_flow_sensitivity = true;      // false with --no-trim (no periodic orbit: route 2 does not exist)
  std::optional<StabilityAnalysis> lti;  // the averaged model's modes of the same subsystem
  Eigen::VectorXcd lti_eigenvalues_nd;
  // Each Floquet mode (phase_resolved.modes) beside the averaged mode of the most similar eigenvector.
  std::vector<ModePair> lti_pairing;
};

struct FloquetStudy {
  // --no-trim: no trim and no periodic orbit; A(t) is the linearisation about the body held at rest at the case's
  // kinematics (the equations of motion with the aerodynamic wrench at zero body motion), route 1 only.
  bool no_trim = false;
  TrimResult averaged_trim;
  DerivativeResult averaged;
  CyclicTrimResult cyclic;
  PhaseDerivatives phase;
  FloquetSubsystem longitudinal, lateral;
  double wall_time_s = 0;
};

// The whole computation for a case (phases = number of phase samples of A(t); 0: the case's
// [aero.quasi_steady] samples_per_cycle). Throws InputError (asymmetric case, model without
// instantaneous loads) or SolveError (trim or cyclic trim not converged).
// `averaged`: the case's averaged trim when the caller has solved it already (analyze), else solved here.
FloquetStudy floquet_study(const Case& c, const AeroModel& model, int phases = 0, const TrimResult* averaged = nullptr,
                           bool no_trim = false);

nlohmann::json floquet_json(const Case& c, const FloquetStudy& s);

// flapstab floquet CASE.toml [--json FILE] [-o DIR]: writes floquet.json to DIR and/or FILE.
int run_floquet(const CommandOptions& o);

}  // namespace flapstab
