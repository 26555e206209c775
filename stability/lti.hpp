// LTI hover systems in the non-dimensional form of docs/derivative-table.md (Sun & Xiong 2005): longitudinal, lateral, coupled 6DoF.
//
// Time t+ = t U / c; velocities u+ = u / U; rates p+ = p c / U; attitudes in rad.
// m+ = m / (1/2 rho S_t c), I+ = I / (1/2 rho S_t c^3), g+ = g c / U^2 (Sun & Xiong 2005, J Exp Biol
// 208:447). Linearised about hover at rest in hover stability axes, so no u0 or gyroscopic terms.
#pragma once
#include <string>
#include <vector>
#include <Eigen/Dense>
#include "core/derivative_table.hpp"

namespace flapstab {

// d/dt+ x = A x + B delta, with the state and input orders named. B has one column per control derivative of
// the table (input delta in the parameter's unit, deg or Hz); it is empty when the table has none.
struct StateSpace {
  std::string name;                      // "longitudinal" | "lateral" | "6dof" (or a caller's name)
  std::vector<std::string> state_order;  // e.g. {"u", "w", "q", "theta"}
  Eigen::MatrixXd A;                     // non-dimensional system matrix
  Eigen::MatrixXd B;                     // non-dimensional input matrix (per t+ and per parameter unit)
  std::vector<std::string> input_order;  // control parameter names, e.g. {"stroke_plane_deg"}
};

struct NonDimensionalParameters {
  double m = 0;                            // m+
  double Ixx = 0, Iyy = 0, Izz = 0, Ixz = 0;  // I+
  double g = 0;                            // g+
  double time_scale_s = 0;                 // c / U: seconds per unit of t+
};

NonDimensionalParameters nondimensional_parameters(const DerivativeTable& table);

// Longitudinal [u, w, q, theta]: the matrix of docs/derivative-table.md, entry for entry.
StateSpace longitudinal_system(const DerivativeTable& table);
// Lateral [v, p, r, phi]: Etkin's body-axis moment equations I_x p' - I_xz r' = L,
// I_z r' - I_xz p' = N (Etkin & Reid 1996, Dynamics of Flight: Stability and Control, 3rd ed.,
// ch. 4) in the scaling above; with I_xz = 0 it is docs/derivative-table.md's matrix exactly.
StateSpace lateral_system(const DerivativeTable& table);
// Coupled [u, v, w, p, q, r, phi, theta]: all 36 derivatives (cross-coupling included) with the full
// inertia matrix; with zero cross-coupling it is the two systems above interleaved.
StateSpace coupled_system(const DerivativeTable& table);

}  // namespace flapstab
