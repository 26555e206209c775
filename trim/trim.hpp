// Hover trim (cycle-averaged): kinematic parameters and body attitude at which the wingbeat-mean
// aerodynamic force balances the weight and the mean moments about the mean CoM vanish.
//
// Equations (stability axes, z down): mean F_x = 0, mean F_z + m g = 0, mean M_y = 0 for a symmetric
// insect; all six components (F + m g e_z = 0, M = 0) when a parameter or the kinematics is one-sided.
// About the wingbeat-mean CoM O, gravity has zero mean moment and the wings' inertial loads have
// zero mean for a fixed body, so only the aerodynamic means enter.
#pragma once
#include <string>
#include <vector>
#include "core/aero_model.hpp"
#include "core/case_file.hpp"

namespace flapstab {

struct TrimParameterValue {
  std::string name, label, unit;
  double value = 0, initial = 0, lower = 0, upper = 0;
};

struct TrimResult {
  bool converged = false;
  bool solved = true;           // false: the case's kinematics evaluated as given (--no-trim), nothing solved
  std::string solver, objective, message;
  int iterations = 0, model_runs = 0;
  std::vector<TrimParameterValue> parameters;
  Kinematics kinematics;        // the trimmed kinematics
  Vec3 force_residual = Vec3::Zero();    // N: mean aero force + weight
  Vec3 moment_residual = Vec3::Zero();   // N m: mean aero moment about O
  double relative_force_residual = 0;    // |force residual| / weight
  double relative_moment_residual = 0;   // |moment residual| / (weight x wing length)
  double mean_power = 0;                 // W, aerodynamic
  double weight = 0;                     // N
  std::vector<std::string> equations;    // the balanced components
  // The parameters that end on a bound ("stroke_amplitude_deg at its upper bound 170 deg"): where an infeasible
  // trim is held; empty when none is.
  std::vector<std::string> active_bounds() const;
};

// Solves the trim of the case's [trim] section with its solver. Throws InputError for an ill-posed
// problem (no or too few parameters); returns converged = false when the solver fails (infeasible).
TrimResult trim_hover(const Case& c, const AeroModel& model);

// The case's kinematics as they are (flapstab --no-trim): the residuals the trim would balance (the same
// equations, the same mean loads), nothing solved; converged tells whether they happen to hold to the tolerance.
TrimResult evaluate_at_case_kinematics(const Case& c, const AeroModel& model);

}  // namespace flapstab
