// The flapstab subcommands as library functions (the CLI in main.cpp only parses arguments).
#pragma once
#include <string>
#include "core/case_file.hpp"

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
