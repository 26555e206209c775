// flapstab cfd: a Navier-Stokes immersed-boundary run of the case's insect ([aero.cfd] settings).
#pragma once
#include <string>

namespace flapstab {

struct CfdCommandOptions {
  std::string case_path;
  std::string output_dir;  // -o DIR ("" = the case's [output] directory)
  bool restart = false;    // --restart: resume from the newest valid checkpoint in DIR
  int cycles = 0;          // --cycles N (> 0 overrides [aero.cfd] cycles)
  bool dry_run = false;    // --dry-run: estimate and checks only, nothing written
  long steps = 0;          // --steps N: at most N steps now, then a checkpoint (a smoke run; --restart continues)
  bool quiet = false;      // no estimate or progress lines
};

// Returns the exit status; InputError (exit 2), SolveError (divergence, exit 3), OutputError (exit 4) and
// Interrupted (SIGINT/SIGTERM after the checkpoint, exit 128 + signal) are thrown.
int run_cfd_command(const CfdCommandOptions& o);

}  // namespace flapstab
