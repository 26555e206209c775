// Periodic CFD runs (periodic.hpp).
#include "cfd/navier_stokes/periodic.hpp"

#include <chrono>
#include <cmath>
#include <ostream>
#include <fmt/format.h>

namespace flapstab::ns {

double cycle_change(const Wrench& a, const Wrench& b, const PeriodicSettings& s) {
  return std::max((a.force - b.force).norm() / s.force_scale, (a.moment - b.moment).norm() / s.moment_scale);
}

WindowStatistics window_statistics(const std::vector<Wrench>& means, const PeriodicSettings& s) {
  WindowStatistics w;
  const int n = int(means.size());
  if (n == 0) return w;
  for (const auto& m : means) w.mean += m;
  w.mean = Wrench{w.mean.force / n, w.mean.moment / n};
  if (n < 2) return w;
  double vf = 0, vm = 0, sjj = 0;
  Vec3 bf = Vec3::Zero(), bm = Vec3::Zero();
  for (int j = 0; j < n; ++j) {
    const Vec3 ef = means[std::size_t(j)].force - w.mean.force, em = means[std::size_t(j)].moment - w.mean.moment;
    vf += ef.squaredNorm();
    vm += em.squaredNorm();
    const double x = j - 0.5 * (n - 1);
    sjj += x * x;
    bf += x * ef;
    bm += x * em;
  }
  w.standard_error =
      std::max(std::sqrt(vf / (n - 1) / n) / s.force_scale, std::sqrt(vm / (n - 1) / n) / s.moment_scale);
  w.drift = (n - 1) * std::max(bf.norm() / sjj / s.force_scale, bm.norm() / sjj / s.moment_scale);
  return w;
}

PeriodicRun run_until_periodic(Simulation& sim, const PeriodicSettings& s, std::ostream* log, const std::string& label,
                               PeriodicRun earlier, const std::function<void(const PeriodicRun&)>& after_wingbeat) {
  const int n = sim.plan().steps_per_cycle;
  if (n <= 0) throw SolveError("periodic CFD run: needs a fixed, phase-locked time step ([aero.cfd] steps_per_cycle)");
  if (sim.step() % n != 0)
    throw SolveError(fmt::format("periodic CFD run: the simulation is at step {}, not on a wingbeat boundary ({} steps "
                                 "per wingbeat)", sim.step(), n));
  const auto t0 = std::chrono::steady_clock::now();
  PeriodicRun run = std::move(earlier);
  const double earlier_seconds = run.wall_seconds;
  auto elapsed = [&] {
    return earlier_seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  for (int cycle = int(run.cycles.size()) + 1; cycle <= s.max_cycles; ++cycle) {
    std::vector<CfdLoadRow> rows;
    rows.reserve(std::size_t(n));
    Wrench sum;
    for (int k = 0; k < n; ++k) {
      rows.push_back(sim.advance().row);
      sum += rows.back().total();
    }
    CycleRecord rec;
    rec.cycle = cycle;
    rec.mean = Wrench{sum.force / n, sum.moment / n};
    if (!run.cycles.empty()) rec.change = cycle_change(rec.mean, run.cycles.back().mean, s);
    run.cycles.push_back(rec);
    run.last_cycle = std::move(rows);
    const double secs = elapsed();
    if (log)
      *log << fmt::format("{}wingbeat {:>2}: mean F = ({:+.4e}, {:+.4e}, {:+.4e}) N, M = ({:+.4e}, {:+.4e}, {:+.4e}) N m, "
                          "change {} ({:.0f} s)\n",
                          label, cycle, rec.mean.force.x(), rec.mean.force.y(), rec.mean.force.z(), rec.mean.moment.x(),
                          rec.mean.moment.y(), rec.mean.moment.z(),
                          rec.change < 0 ? std::string("-") : fmt::format("{:.2e}", rec.change), secs)
           << std::flush;
    if (cycle >= s.min_cycles && rec.change >= 0 && rec.change < s.tolerance) {
      run.converged = true;
      break;
    }
    if (after_wingbeat && cycle < s.max_cycles) {
      run.wall_seconds = secs;
      after_wingbeat(run);
    }
  }
  run.wall_seconds = elapsed();
  return run;
}

}  // namespace flapstab::ns
