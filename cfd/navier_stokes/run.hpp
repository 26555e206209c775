// The CFD run driver: an insect case ([aero] model = "cfd", [aero.cfd]) to a Navier-Stokes immersed-boundary
// run in stability axes, with loads, flow fields, surfaces, checkpoints and exact restart (`flapstab cfd`).
//
// run_cfd is the short loop plan -> Simulation -> observers (simulation.hpp, observers.hpp); set-up and far field
// are described in plan.hpp and simulation.hpp, the files in docs/cfd-files.md.
#pragma once
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>
#include "cfd/fpm/observer.hpp"
#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/forces_csv.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "cfd/navier_stokes/simulation.hpp"
#include "core/aero_model.hpp"
#include "core/case_file.hpp"

namespace flapstab::ns {

// How a run is driven (the CLI's options; "" directory keeps everything in memory).
struct CfdRunOptions {
  std::string directory;        // output directory; "" = keep everything in memory
  bool restart = false;         // resume from the newest valid checkpoint in directory
  int cycles = 0;               // > 0: overrides [aero.cfd] cycles
  bool dry_run = false;         // plan, check, build and time two steps; write nothing
  bool bodies = true;           // false: a body-free flow in the same box (solver checks, tests)
  std::function<Vec3(double x, double y, double z)> initial_velocity;  // default: the uniform stream -V
  std::ostream* log = nullptr;  // estimate and progress lines (nullptr: silent)
  double progress_seconds = 5;  // wall time between progress lines
  long stop_after_steps = 0;    // > 0: stop after this step as if interrupted (forces.csv flushed, no final
                                // checkpoint or run.json): for tests of --restart and for runs in pieces
  long steps = 0;               // > 0: run at most this many steps now (`--steps`), then stop with a checkpoint,
                                // forces.csv and run.json (status "stopped"); --restart continues
  bool handle_signals = true;   // SIGINT/SIGTERM: stop at the end of the step, checkpoint, throw Interrupted
  // The grid split over MPI ranks (decomposition.hpp; every rank calls run_cfd alike): the files are the whole
  // grid's, written by rank 0 (forces.csv, run.json, checkpoints that restart on any number of ranks, fields,
  // surfaces), the log is rank 0's, and every rank returns the result. Null: one process. Force partitioning is
  // refused over ranks (InputError).
  std::shared_ptr<const Decomposition> decomposition{};
  double pressure_rtol = 0;  // > 0: the pressure solves' tolerance (SimulationOptions::pressure_rtol; tests)
};

// The result of a run: the mean loads over its last complete wingbeat, the start-up wingbeat from rest excluded.
struct CfdRunResult {
  bool available = false;     // false: no rows
  int wingbeat = 0;           // 1-based wingbeat averaged
  bool complete = false;      // the window is a whole wingbeat
  bool includes_startup = false;  // the window is (part of) the first wingbeat from rest: not a hover result
  double from_s = 0, to_s = 0;
  Wrench mean;                // N, N m about O, stability axes
  Wrench part_mean[max_parts];  // body, right, left[, hind_right, hind_left] (part_names)
  int parts = 3;              // parts in part_mean: 3, or 5 with a hind pair
  double wing_power = 0;      // W
  double weight = 0;          // N
  double lift_over_weight = 0;  // -F_z / (m g)
  std::string note;           // what the window is, in words
};

struct CfdResult {
  CfdPlan plan;
  std::size_t cells = 0;
  std::size_t bytes = 0;         // solver + immersed boundary
  long steps = 0;                // step counter at the end
  long start_step = 0;           // 0, or the checkpoint's step on restart
  double seconds_per_step_estimate = 0;  // timed on the first two steps
  double seconds_per_step = 0;           // measured over the run (steps after the first two)
  double wall_seconds = 0;
  std::vector<CfdLoadRow> rows;  // every step of this run (restart: from the checkpoint on)
  std::vector<CfdLoadRow> last_cycle;  // rows of the last wingbeat (restart: with those of the earlier run)
  std::string restarted_from;    // checkpoint path
  std::string status;            // "complete", "stopped" (--steps), "nothing to do" (a restart of a finished run)
  CfdRunResult result;
  // Force partitioning ([aero.cfd.fpm]; cfd/fpm/observer.hpp): every row (restart: with the interrupted run's), the
  // region names of the vortex columns, the wingbeat means of run.json and the terminal summary.
  std::vector<fpm::FpmRow> fpm_rows;
  std::vector<std::string> fpm_regions;
  std::string fpm_means_json;  // the "fpm" object of run.json ("" without force partitioning)
  std::string fpm_summary;
  double fpm_seconds = 0;      // wall time spent partitioning
};

// The result over rows `rows` (earlier and this run's) of a run of `plan` at time `t_end_run` (see CfdRunResult).
CfdRunResult cfd_run_result(const std::vector<CfdLoadRow>& rows, const CfdPlan& plan, double weight);
// One paragraph for the terminal: the window and the mean loads, lift / weight and wing power.
std::string cfd_run_result_text(const CfdRunResult& r);

// Bad input (InputError naming `file` and `key`, e.g. "mpiexec -n") when `ranks` MPI ranks cannot share the plan's grid
// in z slabs (Solver::split_problem; `bodies`: with the immersed boundary's windows); the hint names the most ranks
// that can. Nothing for one rank.
void check_ranks_share_grid(const CfdPlan& plan, int ranks, bool bodies, const std::string& file,
                            const std::string& key);

// The run. Throws InputError for bad input (before writing anything), SolveError on divergence (after keeping
// the last checkpoint; the message gives step and time).
CfdResult run_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, const CfdRunOptions& options);

// The case hash in checkpoints and in the CFD model's kept runs (16 hex digits, FNV-1a 64): of the case file's
// content that the flow depends on, i.e. the TOML document without the tables that only say what is done with the
// runs ([trim], [derivatives], [flight], [control], [output]; a trim's result enters the runs' keys through the
// kinematics instead), re-serialised, so comments, layout and those tables can change without invalidating kept
// hover states, runs and checkpoints. A file that does not parse hashes by its bytes. Files the case refers to
// (tables, kinematics files) are not part of it.
std::string case_hash(const std::string& path);

}  // namespace flapstab::ns
