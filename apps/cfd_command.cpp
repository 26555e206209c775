// flapstab cfd: loads the case, runs cfd/navier_stokes/run, prints the result and plots the force history.
#include "apps/cfd_command.hpp"
#include "apps/commands.hpp"

#include <iostream>
#include <fmt/format.h>

#include "apps/plots.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "cfd/navier_stokes/run.hpp"
#include "core/atomic_write.hpp"
#include "core/case_file.hpp"
#include "core/errors.hpp"

namespace flapstab {

namespace {

// forces.svg: lift / weight and the forward and side forces / weight over t/T, every row of the run (a restarted
// run: the interrupted run's rows too), with the result's window marked.
void plot_force_history(const std::string& dir, const ns::CfdResult& r, bool quiet) {
  std::vector<ns::CfdLoadRow> rows;
  std::string why;
  ns::ForcesCsv csv("");
  try {
    csv.keep_earlier(dir + "/forces.csv", r.steps);
  } catch (const InputError& e) {
    if (!quiet) fmt::print(stderr, "flapstab cfd: no forces.svg: {}\n", e.what());
    return;
  }
  rows = csv.earlier();
  if (rows.empty() || r.result.weight <= 0) return;
  const double T = r.plan.period, W = r.result.weight;
  Series lift{"lift / weight (-F_z / m g)", {}, {}}, fx{"F_x / weight (forward)", {}, {}}, fy{"F_y / weight (right)", {}, {}};
  for (const auto& row : rows) {
    const Vec3 F = row.total().force;
    for (Series* s : {&lift, &fx, &fy}) s->x.push_back(row.time / T);
    lift.y.push_back(-F.z() / W);
    fx.y.push_back(F.x() / W);
    fy.y.push_back(F.y() / W);
  }
  LinePlot p;
  p.title = fmt::format("flapstab cfd: force history; result: {} (mean lift / weight {:.3f})",
                        r.result.complete && !r.result.includes_startup ? fmt::format("wingbeat {}", r.result.wingbeat)
                                                                        : std::string("start-up only"),
                        r.result.lift_over_weight);
  p.xlabel = "t / T (wingbeats)";
  p.ylabel = "force / weight";
  p.zero_axes = true;
  p.series = {lift, fx, fy};
  if (r.result.available)
    p.series.push_back(Series{"mean lift / weight over the result's window",
                              {r.result.from_s / T, r.result.to_s / T},
                              {r.result.lift_over_weight, r.result.lift_over_weight}});
  const auto svg = render_svg(p, why);
  if (!svg) {
    if (!quiet) fmt::print(stderr, "flapstab cfd: no forces.svg: {}\n", why);
    return;
  }
  write_file_atomic(dir + "/forces.svg", *svg);
}

}  // namespace

int run_cfd_command(const CfdCommandOptions& o) {
  const Case c = load_case_for(o.case_path, "cfd");
  ns::CfdRunOptions opt;
  opt.directory = o.output_dir.empty() ? c.output_directory : o.output_dir;  // read on --restart; never written by a dry run
  opt.restart = o.restart;
  opt.cycles = o.cycles;
  opt.dry_run = o.dry_run;
  opt.steps = o.steps;
  opt.log = o.quiet ? nullptr : &std::cerr;
  const ns::CfdResult r = ns::run_cfd(c, c.kinematics, BodyMotion{}, opt);
  if (r.status == "nothing to do") {
    if (!o.quiet) fmt::print("nothing to do: {} is complete ({} steps); no file changed\n", opt.directory, r.steps);
    return 0;
  }
  if (!o.dry_run) plot_force_history(opt.directory, r, o.quiet);
  if (!o.quiet) {
    if (o.dry_run)
      fmt::print("dry run: {} cells, {:.1f} MiB, {:.3g} s per step; nothing written\n", r.cells, r.bytes / 1048576.0,
                 r.seconds_per_step_estimate);
    else {
      fmt::print("wrote {0}/forces.csv, {0}/forces.svg, {0}/run.json, {0}/fields, {0}/surfaces, {0}/checkpoints ({1} "
                 "steps, {2:.1f} s){3}\n",
                 opt.directory, r.steps, r.wall_seconds,
                 r.status == "stopped" ? fmt::format("; stopped after --steps {}: continue with --restart", o.steps)
                                       : std::string());
      if (r.result.available) fmt::print("{}", ns::cfd_run_result_text(r.result));
    }
  }
  return 0;
}

}  // namespace flapstab
