// flapstab cfd: loads the case, runs cfd/navier_stokes/run, prints the result and plots the force history.
#include "apps/cfd_command.hpp"
#include "apps/over_ranks.hpp"
#include "apps/commands.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
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
  ns::ForcesCsv csv("", r.plan.parts);  // rows of the run's geometry: 3 parts, or 5 with a hind pair
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

// fpm.svg: the wings' lift (-F_z, both wings) by mechanism over t/T, / weight: the run's pressure lift, the cut-cell
// pressure lift the partition should sum to and its actual sum, its kinematic part (added mass and centripetal acceleration reaction apart),
// vortex-induced part (and its leading-edge regions), viscous and outer-boundary parts.
void plot_partition_history(const std::string& dir, const ns::CfdResult& r, bool quiet) {
  if (r.fpm_rows.empty() || r.result.weight <= 0) return;
  const double T = r.plan.period, W = r.result.weight;
  std::vector<std::size_t> le;  // the leading-edge region columns
  for (std::size_t i = 0; i < r.fpm_regions.size(); ++i)
    if (r.fpm_regions[i].find("leading-edge") != std::string::npos) le.push_back(i);
  struct Sum {
    double t = 0, solver = 0, pressure = 0, forced = 0, added = 0, car = 0, vortex = 0, lev = 0, viscous = 0, outer = 0;
    double sum() const { return added + car + vortex + viscous + outer; }
  };
  std::vector<Sum> samples;  // wing rows of F_z, summed per sample
  for (const auto& row : r.fpm_rows) {
    if (row.part == 0 || row.component != 2) continue;
    if (samples.empty() || samples.back().t != row.time) samples.push_back(Sum{row.time});
    Sum& m = samples.back();
    m.solver -= row.solver_pressure / W, m.pressure -= row.pressure / W, m.added -= row.added_mass() / W;
    m.forced -= row.pressure_forced / W;
    m.car -= row.centripetal / W, m.vortex -= row.vortex / W, m.viscous -= row.viscous / W, m.outer -= row.outer / W;
    for (std::size_t i : le) m.lev -= row.regions[i] / W;
  }
  if (samples.empty()) return;  // F_z not partitioned or no wing
  std::vector<Series> series = {{"run's pressure lift (forces.csv)", {}, {}},
                                {"pressure lift on the partition's body (fpm.csv pressure)", {}, {}},
                                {"cut-cell pressure lift off the forced faces (what the parts sum to)", {}, {},
                                 "lines dt 2"},
                                {"sum of the parts", {}, {}, "lines dt 3"},
                                {"added mass", {}, {}},
                                {"centripetal acceleration reaction", {}, {}},
                                {"vortex-induced", {}, {}},
                                {"vortex-induced, leading-edge regions", {}, {}, "lines dt 2"},
                                {"viscous", {}, {}},
                                {"outer boundary", {}, {}}};
  for (const Sum& m : samples) {
    const double v[10] = {m.solver,   m.pressure, m.pressure - m.forced, m.sum(),   m.added,
                          m.car,      m.vortex,   m.lev,                 m.viscous, m.outer};
    for (int i = 0; i < 10; ++i) {
      series[std::size_t(i)].x.push_back(m.t / T);
      series[std::size_t(i)].y.push_back(v[i]);
    }
  }
  if (le.empty()) series.erase(series.begin() + 7);
  // with the forced region as the body no forced face is open: the curve would repeat the one above it
  if (std::all_of(samples.begin(), samples.end(), [](const Sum& m) { return m.forced == 0; }))
    series.erase(series.begin() + 2);
  LinePlot p;
  p.title = "flapstab cfd: force partition of the wings' lift";
  p.xlabel = "t / T (wingbeats)";
  p.ylabel = "lift / weight (-F_z / m g, both wings)";
  p.zero_axes = true;
  p.series = series;
  std::string why;
  const auto svg = render_svg(p, why);
  if (!svg) {
    if (!quiet) fmt::print(stderr, "flapstab cfd: no fpm.svg: {}\n", why);
    return;
  }
  write_file_atomic(dir + "/fpm.svg", *svg);
}

// One run of flapstab cfd: in this process, or as one rank of a decomposed run (dec).
int run_cfd_process(const CfdCommandOptions& o, const std::shared_ptr<const ns::Decomposition>& dec) {
  const Case c = load_case_for(o.case_path, "cfd");
  const bool root = !dec || dec->rank() == 0;
  ns::CfdRunOptions opt;
  opt.directory = o.output_dir.empty() ? c.output_directory : o.output_dir;  // read on --restart; never written by a dry run
  opt.restart = o.restart;
  opt.cycles = o.cycles;
  opt.dry_run = o.dry_run;
  opt.steps = o.steps;
  opt.log = o.quiet || !root ? nullptr : &std::cerr;
  opt.decomposition = dec;
  const ns::CfdResult r = ns::run_cfd(c, c.kinematics, BodyMotion{}, opt);
  if (!root) return 0;  // rank 0 plots and reports
  if (r.status == "nothing to do") {
    if (!o.quiet) fmt::print("nothing to do: {} is complete ({} steps); no file changed\n", opt.directory, r.steps);
    return 0;
  }
  if (!o.dry_run) {
    plot_force_history(opt.directory, r, o.quiet);
    plot_partition_history(opt.directory, r, o.quiet);
  }
  if (!o.quiet) {
    if (o.dry_run)
      fmt::print("dry run: {} cells, {:.1f} MiB, {:.3g} s per step; nothing written\n", r.cells, r.bytes / 1048576.0,
                 r.seconds_per_step_estimate);
    else {
      // what the run left in its directory (fields and surfaces only when their outputs are on)
      std::string files;
      for (const char* f : {"forces.csv", "forces.svg", "run.json", "fpm.csv", "fpm.svg", "fields", "surfaces",
                            "checkpoints"})
        if (std::filesystem::exists(opt.directory + "/" + f)) files += (files.empty() ? "" : ", ") + opt.directory + "/" + f;
      fmt::print("wrote {} ({} steps, {:.1f} s){}\n", files, r.steps, r.wall_seconds,
                 r.status == "stopped" ? fmt::format("; stopped after --steps {}: continue with --restart", o.steps)
                                       : std::string());
      if (r.result.available) fmt::print("{}", ns::cfd_run_result_text(r.result));
    }
  }
  return 0;
}

}  // namespace

int run_cfd_command(const CfdCommandOptions& o) {
  // Started by mpiexec as several processes: one flow over them all, the grid in slabs (one per rank); rank 0 writes
  // the run's files and speaks for all.
  const std::shared_ptr<const ns::Decomposition> dec = ns::Decomposition::launched();
  if (!dec->distributed()) return run_cfd_process(o, nullptr);
  return run_over_ranks(*dec, "flapstab cfd", [&] { return run_cfd_process(o, dec); });
}

}  // namespace flapstab
