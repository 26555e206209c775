// The `fly` and `control-map` subcommands: free flight of the trimmed insect with its controller, and the
// delay-exact (gain, latency) stability map of the pitch controller with simulated check points.
#pragma once
#include <string>

namespace flapstab {

struct FlightCommandOptions {
  std::string case_path, output_dir;
  std::string dof;        // overrides [flight] dof ("" = the case's)
  double wingbeats = 0;   // overrides [flight] wingbeats (0 = the case's)
  bool com_sweep = false; // control-map: also sweep the centre of mass height against the neutral axis
  bool quiet = false;
};

// flapstab fly CASE -o DIR: trajectory.csv, run.json, response.svg.
int run_fly(const FlightCommandOptions& o);
// flapstab control-map CASE -o DIR: control_map.json, control_map.csv, control_map.svg.
int run_control_map(const FlightCommandOptions& o);

}  // namespace flapstab
