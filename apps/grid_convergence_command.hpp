// flapstab grid-convergence: the discretisation error of a CFD derivative table from the same table computed on two
// or three grids (each a `flapstab derivatives`, `stability` or `analyze` result of a case with [aero] model =
// "cfd"): per derivative the Richardson-extrapolated value, the apparent (three grids) or assumed (two grids) order
// and the grid-convergence index (core/grid_convergence.hpp), beside the runs' own statistical uncertainty.
#pragma once
#include <string>
#include <vector>

namespace flapstab {

struct GridConvergenceOptions {
  std::vector<std::string> inputs;  // derivatives.json / results.json / stability.json files, or directories holding one
  double order = 1.0;               // the order assumed with two grids (and where three give none)
  std::string output_dir;           // grid_convergence.json and grid_convergence.md ("" = print only)
  std::string json_path;
  bool quiet = false;
};

int run_grid_convergence(const GridConvergenceOptions& o);

}  // namespace flapstab
