// flapstab validate: the published validation cases run as a user would run them, each ending with its
// comparison against the published numbers (docs/validation.md).
#pragma once
#include <string>

namespace flapstab {

struct ValidateCommandOptions {
  std::string output_dir = "validate-hovering-2d";
  std::string reference_dir;    // "" = the shipped data (share/flapstab/reference/... or the source tree's data/)
  double cells_per_chord = 32;  // the fine box's spacing c / N
  double cycles = 4;
  int span_cells = 2;  // at least 2 (cfd/navier_stokes/hovering_2d.hpp)
  bool quiet = false;
};

// The 2-D hovering wing of Wang, Birch & Dickinson 2004 (cfd/navier_stokes/hovering_2d.hpp): history.csv,
// summary.json and forces.svg in the output directory, written as one set at the end.
int run_validate_hovering_2d(const ValidateCommandOptions& o);

}  // namespace flapstab
