// flapstab cfd: loads the case, runs cfd/navier_stokes/run and reports where the outputs went.
#include "apps/cfd_command.hpp"

#include <iostream>
#include <fmt/format.h>

#include "cfd/navier_stokes/run.hpp"
#include "core/case_file.hpp"

namespace flapstab {

int run_cfd_command(const CfdCommandOptions& o) {
  const Case c = load_case(o.case_path);
  ns::CfdRunOptions opt;
  opt.directory = o.output_dir.empty() ? c.output_directory : o.output_dir;  // read on --restart; never written by a dry run
  opt.restart = o.restart;
  opt.cycles = o.cycles;
  opt.dry_run = o.dry_run;
  opt.log = o.quiet ? nullptr : &std::cerr;
  const ns::CfdResult r = ns::run_cfd(c, c.kinematics, BodyMotion{}, opt);
  if (!o.quiet) {
    if (o.dry_run)
      fmt::print("dry run: {} cells, {:.1f} MiB, {:.3g} s per step; nothing written\n", r.cells, r.bytes / 1048576.0,
                 r.seconds_per_step_estimate);
    else
      fmt::print("wrote {0}/forces.csv, {0}/run.json, {0}/fields, {0}/surfaces, {0}/checkpoints ({1} steps, {2:.1f} s)\n",
                 opt.directory, r.steps, r.wall_seconds);
  }
  return 0;
}

}  // namespace flapstab
