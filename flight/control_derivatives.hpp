// Control derivatives: d(cycle-mean wrench)/d(kinematic parameter), the B matrix beside the stability derivatives.
//
// Central differences of the model's cycle-mean wrench in each actuated parameter (step 0.5 deg, or 0.5 % of
// the frequency), with the moments moved to the trimmed reference point O (the parameter moves the wings' mean
// mass, so the perturbed kinematics' own O moves) and the gravitational moment of the moved centre of mass
// added: at hover (gravity along +z) the mean CoM offset d from O gives M_g = d x (0, 0, m g).
#pragma once
#include <vector>
#include "core/aero_model.hpp"
#include "core/case_file.hpp"
#include "core/derivative_table.hpp"

namespace flapstab {

struct ControlDerivativeResult {
  std::vector<ControlDerivative> columns;  // non-dimensional, per parameter unit (as in the derivative table)
  Eigen::MatrixXd si;                      // 6 x n: N and N m per parameter unit, about the trimmed O
  Eigen::MatrixXd gravity_si;              // 6 x n: the gravitational part of si (moment rows only)
  std::vector<double> steps;               // the central-difference steps (parameter units)
  int model_runs = 0;
};

ControlDerivativeResult control_derivatives(const AeroModel& model, const Insect& insect, const Kinematics& trimmed,
                                            const std::vector<TrimParameterSpec>& parameters,
                                            const ReferenceQuantities& ref,
                                            std::optional<double> gravity = std::nullopt,  // default: insect.gravity
                                            const AeroRunOptions& run = {});

// The parameters a case can actuate: its [[trim.parameter]] entries and its [control] actuators, each once.
std::vector<TrimParameterSpec> actuated_parameters(const Case& c);

}  // namespace flapstab
