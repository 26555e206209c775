// JSON and Markdown forms of stability results (keys documented in docs/derivative-table.md).
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include "stability/analysis.hpp"

namespace flapstab {

// One mode; complex numbers as [re, im], eigenvector components in `state_order`.
nlohmann::json to_json(const Mode& mode, const std::vector<std::string>& state_order);
// state_order, state_units, system_matrix_nd (rows), participation_measure, modes.
nlohmann::json to_json(const StabilityAnalysis& analysis);
// conventions, units, source, reference, nondimensional_parameters, then `longitudinal`, `lateral`
// and (when requested) `6dof` — null where skipped — and `notices`.
nlohmann::json to_json(const StabilityReport& report);

// Each mode of the coupled 6DoF analysis beside the longitudinal or lateral mode it is (pair_modes with each
// subsystem, the more similar kept); analysis empty where neither pairs with it.
struct SubsystemMatch {
  std::size_t coupled = 0;  // index in the 6DoF modes
  std::string analysis;     // "longitudinal" | "lateral" | ""
  std::size_t index = 0;    // in that analysis' modes
  std::string name;
  double similarity = 0;
};
std::vector<SubsystemMatch> subsystem_correspondence(const StabilityReport& report);

// Markdown table of one analysis' modes, preceded by its state order and units (for report.md).
std::string modes_markdown(const StabilityAnalysis& analysis);
// Every analysis of the report under its own heading, then the notices.
std::string stability_markdown(const StabilityReport& report);

}  // namespace flapstab
