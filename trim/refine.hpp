// Trim refinement on an expensive model (CFD): a quasi-Newton (Broyden) iteration on the cycle-mean residuals,
// started from a trim of a cheap model (quasi-steady) with that model's Jacobian as the first Jacobian.
//
// Residuals: the trim's equations (trim.hpp: X, Z, M for a symmetric insect, all six otherwise), forces as
// fractions of the weight, moments of weight x wing length. Each iteration: one run of the model at the new
// parameters; the step is the minimum-norm solution of J dx = -r, shortened to at most a quarter of each
// parameter's bound range and held within the bounds; Broyden's
// update J += (dr - J dx) dx^T / (dx^T dx) (Broyden 1965, Math Comp 19:577). Converged when every residual is at or
// below the tolerance.
#pragma once
#include <iosfwd>
#include <vector>
#include "trim/trim.hpp"

namespace flapstab {

struct RefineSettings {
  double tolerance = 0.02;  // |residual| per equation, fraction of the weight (forces) or weight x R (moments)
  int max_iterations = 6;   // model runs after the first
};

// `start`: a trim of the case's [trim] parameters with `start_model`; `model`: the model to trim on. The result's
// iterations and model_runs count the runs of `model`; converged as above.
TrimResult refine_trim(const Case& c, const AeroModel& model, const AeroModel& start_model, const TrimResult& start,
                       const RefineSettings& settings, std::ostream* log = nullptr);

// The kinematics a refinement may visit: the start, and each parameter at its lower and upper bound with the others
// at the start (for planning one CFD grid that holds them all).
std::vector<Kinematics> trim_extreme_kinematics(const Case& c, const TrimResult& start);

}  // namespace flapstab
