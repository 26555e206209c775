// Cycle-averaged stability derivatives over any AeroModel, by central differences in u, v, w, p, q, r.
#pragma once
#include <ostream>
#include "core/aero_model.hpp"
#include "core/case_file.hpp"
#include "cfd/phase_derivatives.hpp"
#include "core/derivative_table.hpp"

namespace flapstab {

// U = 2 Phi n r2 (Phi: peak-to-peak stroke amplitude, rad), c = mean chord, S_t = both wings' area.
ReferenceQuantities reference_quantities(const Insect& insect, const Kinematics& kin, const FluidProperties& fluid);
// Total mass and the wingbeat-mean inertia of body + wings about O in stability axes.
MassProperties mass_properties(const Insect& insect, const Kinematics& kin);

struct DerivativeResult {
  DerivativeTable table;                        // non-dimensional, with reference and mass
  Eigen::Matrix<double, 6, 6> si;               // dimensional: rows X Y Z (N) L M N (N m); cols u v w (m/s) p q r (rad/s)
  Wrench mean_at_trim;                          // mean wrench at the unperturbed state
  double velocity_step = 0, rate_step = 0;      // the steps used (m/s, rad/s)
  int model_runs = 0;
  // Linearity check per derivative: |(W+ - W0) + (W- - W0)| / |W+ - W-|, the asymmetry of the two one-sided
  // differences relative to their sum (0 for a linear response; 0 where W+ = W-).
  Eigen::Matrix<double, 6, 6> asymmetry = Eigen::Matrix<double, 6, 6>::Zero();
  // Statistical uncertainty of each non-dimensional derivative where the model's runs have one (the CFD model's
  // perturbed runs: the standard errors of their wingbeat-mean differences; see cfd_study); negative = none.
  Eigen::Matrix<double, 6, 6> standard_error_nd = Eigen::Matrix<double, 6, 6>::Constant(-1.0);
};

// The columns (0..5 = u v w p q r) of a [derivatives] columns setting: "all", "longitudinal" (u w q) or
// "lateral" (v p r).
std::vector<int> derivative_columns(const std::string& set);

// The body motion of one derivative run: column j (0..5 = u v w p q r) stepped by sign (+1 or -1) times h U
// (velocities) or h_r U / c (rates; h_r = relative_rate_step, or h where that is 0). The same values the functions
// below use, so a model's runs made one by one are found again by them (the CFD model's run keys).
BodyMotion derivative_perturbation(const ReferenceQuantities& ref, double relative_step, double relative_rate_step,
                                   int column, int sign);

// One derivative run that failed: its column, its sign and the model's message.
struct DerivativeRunFailure {
  int column = 0, sign = 0;
  std::string message;
};
// Makes every run of the given columns once, in table order (u+, u-, w+, ...), and goes on past a run that throws
// SolveError (a CFD run that diverged): the model keeps the runs that finished (the CFD model in memory and in its
// cache), so cycle_averaged_derivatives over the columns whose two runs finished then runs nothing new, and a rerun
// of a study repeats only the failed runs. A run another process is computing (a campaign sharing the CFD run cache)
// is passed over and waited for after the others (AeroRunOptions::defer_held). Returns the failures (empty: every run
// finished).
std::vector<DerivativeRunFailure> make_derivative_runs(const AeroModel& model, const Insect& insect,
                                                       const Kinematics& kin, const FluidProperties& fluid,
                                                       double relative_step, double relative_rate_step,
                                                       const std::vector<int>& columns, std::ostream* log = nullptr);

// Central differences of the cycle-mean wrench about O with steps h U (velocities) and h_r U / c (rates; h_r =
// relative_rate_step, or h where that is 0), for the
// given columns (the others stay zero and the table's has_longitudinal / has_lateral / has_coupling say which
// planes it holds: longitudinal = u w q, lateral = v p r).
DerivativeResult cycle_averaged_derivatives(const AeroModel& model, const Insect& insect, const Kinematics& kin,
                                            const FluidProperties& fluid, double relative_step,
                                            const AeroRunOptions& run = {},
                                            const std::vector<int>& columns = {0, 1, 2, 3, 4, 5},
                                            double relative_rate_step = 0);  // 0: relative_step

// Phase-resolved derivatives from the same periodic runs as the cycle-averaged ones (any AeroModel; with the CFD
// model, the runs its cycle-averaged table made): at each of the N phases of the runs' wingbeats,
// d W(t_k) / d x by central differences of the steady-perturbation runs, combined with the linearised equations of
// motion about hover with the body held still (as phase_resolved_derivatives about the rest orbit). For the
// quasi-steady model this is the instantaneous linearisation; for the CFD model it is the periodic response to a
// steady perturbation, phase by phase (its wake memory included).
// Only the given columns are run (the others' derivatives are zero).
PhaseDerivatives phase_resolved_from_runs(const AeroModel& model, const Insect& insect, const Kinematics& kin,
                                          const ReferenceQuantities& reference, double relative_step,
                                          std::optional<double> g = std::nullopt,  // default: insect.gravity
                                          const std::vector<int>& columns = {0, 1, 2, 3, 4, 5},
                                          double relative_rate_step = 0);  // 0: relative_step

// `ph` (phase_resolved_from_runs of the same model, insect and kinematics) with its pitch-rate column's longitudinal
// rows (X Z M) replaced and an aerodynamic pitch-attitude column added, sample by sample: rate_si[k] and theta_si[k]
// hold d[X Y Z L M N]/dq (N s, N m s) and d[X Y Z L M N]/dtheta (N, N m per rad) at ph.samples[k], e.g. the forced
// pitch oscillation's phase-resolved fits (cfd/navier_stokes/oscillation.hpp). Only their X, Z and M rows are used.
using WrenchColumn = Eigen::Matrix<double, 6, 1>;
PhaseDerivatives with_pitch_columns(const PhaseDerivatives& ph, const AeroModel& model, const Insect& insect,
                                    const Kinematics& kin, const std::vector<WrenchColumn>& rate_si,
                                    const std::vector<WrenchColumn>& theta_si,
                                    std::optional<double> g = std::nullopt);  // default: insect.gravity

}  // namespace flapstab
