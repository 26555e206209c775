// The `fly` and `control-map` subcommands: free flight of the trimmed insect with its controller, and the
// delay-exact (gain, latency) stability map of the pitch controller with simulated check points.
#pragma once
#include <memory>
#include <string>
#include <vector>

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
// flapstab fly with [aero] model = "cfd" (apps/flight_cfd.cpp), after run_fly's checks of the case: free flight
// coupled to the Navier-Stokes solver; trajectory.csv, steps.csv, run.json, response.svg and a checkpoint.
struct Case;
enum class DofSet;
struct ControllerSpec;
struct Kinematics;
struct TrimParameterSpec;
// The case's controller ([control]) for the trimmed kinematics, validated (InputError naming the key); empty for
// type = "none".
ControllerSpec controller_from_case(const Case& c, const Kinematics& kin);
// The actuators a controller drives, with their absolute limits (parameter units).
std::vector<TrimParameterSpec> controller_actuators(const Case& c);
// Over MPI ranks (`ranks`: all of an mpiexec job; null for one process) every flow runs over all of them, the grid in
// z slabs; rank 0 prints and writes the files.
namespace ns {
class Decomposition;
}
int run_fly_cfd(const FlightCommandOptions& o, const Case& c, const std::string& dir, DofSet dofs, double wingbeats,
                const std::vector<int>& moving, std::shared_ptr<const ns::Decomposition> ranks = {});
// flapstab control-map CASE -o DIR: control_map.json, control_map.csv, control_map.svg.
int run_control_map(const FlightCommandOptions& o);

}  // namespace flapstab
