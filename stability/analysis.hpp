// Stability of a derivative table: the longitudinal, lateral and (on request) coupled 6DoF analyses.
#pragma once
#include <optional>
#include <string>
#include <vector>
#include "core/derivative_table.hpp"
#include "stability/lti.hpp"
#include "stability/modes.hpp"

namespace flapstab {

struct StabilityRequest {
  bool six_dof = false;  // also analyse the coupled [u, v, w, p, q, r, phi, theta] system
  ModeOptions modes;
};

struct StabilityReport {
  std::string source;                       // the table's source
  ReferenceQuantities reference;
  NonDimensionalParameters nondimensional;  // m+, I+, g+, c/U
  bool six_dof_requested = false;
  std::optional<StabilityAnalysis> longitudinal, lateral, coupled;
  std::vector<std::string> notices;         // analyses skipped and why; derivatives left unused
};

// Runs every analysis the table supports; one whose derivative section is absent is skipped with
// a notice rather than an error.
StabilityReport analyse_stability(const DerivativeTable& table, const StabilityRequest& request = {});

}  // namespace flapstab
