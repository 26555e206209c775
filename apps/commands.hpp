// The flapstab subcommands as library functions (the CLI in main.cpp only parses arguments).
#pragma once
#include <memory>
#include <string>
#include "core/case_file.hpp"

namespace flapstab {
namespace ns {
class Decomposition;
}

struct CommandOptions {
  std::string case_path;     // CASE.toml
  std::string derivatives_path;  // stability: --derivatives TABLE.toml instead of a case
  std::string model = "6dof";    // stability: longitudinal | lateral | 6dof
  std::string json_path;     // --json FILE ("" = none)
  std::string output_dir;    // -o DIR ("" = none)
  bool quiet = false;
  bool no_trim = false;      // --no-trim: evaluate at the case's kinematics as they are (derivatives, stability,
                             // floquet, analyze), the residual reported instead of balanced
  // --ranks-per-flow K (trim-hover, derivatives, stability, analyze with the CFD model, under mpiexec -n N, N a
  // multiple of K): the job's ranks in N / K groups, each running the CFD model's flows over its K ranks (the grid in
  // z slabs), the groups sharing the run cache as a campaign's processes do. 0: not given (each process alone).
  int ranks_per_flow = 0;
  // This process's group (set by run_in_flow_groups); its rank 0 logs and writes the command's files.
  std::shared_ptr<const ns::Decomposition> flow_ranks;
};

// Runs a command (run_trim_hover, ...) in this process's group of --ranks-per-flow ranks: checks the option against
// the ranks mpiexec started (InputError naming --ranks-per-flow), makes the groups (collective over the job) and ends
// the group's ranks together on an error (run_over_ranks). Without the option, command(o).
int run_in_flow_groups(CommandOptions o, const std::string& name, int (*command)(const CommandOptions&));

// load_case for every command but floquet: a case with [body_motion] (the translation-only model, which only
// `flapstab floquet` solves) is refused with an InputError naming body_motion, before anything is computed or written.
Case load_case_for(const std::string& path, const std::string& command);

// Each returns the process exit status; errors are thrown (InputError, SolveError) and mapped to
// exit statuses by main().
int run_trim_hover(const CommandOptions& o);
int run_derivatives(const CommandOptions& o);
int run_stability(const CommandOptions& o);
// The main job: trim -> derivatives -> stability -> report.md, report.html, results.json, derivatives.toml.
int run_analyze(const CommandOptions& o);

}  // namespace flapstab
