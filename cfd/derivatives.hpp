// Cycle-averaged stability derivatives over any AeroModel, by central differences in u, v, w, p, q, r.
#pragma once
#include "core/aero_model.hpp"
#include "core/case_file.hpp"
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
};

// Central differences of the cycle-mean wrench about O with steps h U (velocities) and h U / c (rates).
DerivativeResult cycle_averaged_derivatives(const AeroModel& model, const Insect& insect, const Kinematics& kin,
                                            const FluidProperties& fluid, double relative_step,
                                            const AeroRunOptions& run = {});

}  // namespace flapstab
