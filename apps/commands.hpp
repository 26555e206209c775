// The flapstab subcommands as library functions (the CLI in main.cpp only parses arguments).
#pragma once
#include <string>

namespace flapstab {

struct CommandOptions {
  std::string case_path;     // CASE.toml
  std::string derivatives_path;  // stability: --derivatives TABLE.toml instead of a case
  std::string model = "6dof";    // stability: longitudinal | lateral | 6dof
  std::string json_path;     // --json FILE ("" = none)
  std::string output_dir;    // -o DIR ("" = none)
  bool quiet = false;
  bool no_trim = false;      // --no-trim: evaluate at the case's kinematics as they are (derivatives, stability,
                             // floquet, analyze), the residual reported instead of balanced
};

// Each returns the process exit status; errors are thrown (InputError, SolveError) and mapped to
// exit statuses by main().
int run_trim_hover(const CommandOptions& o);
int run_derivatives(const CommandOptions& o);
int run_stability(const CommandOptions& o);
// The main job: trim -> derivatives -> stability -> report.md, report.html, results.json, derivatives.toml.
int run_analyze(const CommandOptions& o);

}  // namespace flapstab
