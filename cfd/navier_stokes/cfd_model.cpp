// The AeroModel over the CFD driver (cfd_model.hpp).
#include "cfd/navier_stokes/cfd_model.hpp"

#include <algorithm>
#include <chrono>
#include <fmt/format.h>

#include "cfd/navier_stokes/run.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

WrenchHistory CfdModel::run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                            const AeroRunOptions& options) const {
  Case c = case_;
  c.insect = insect;
  CfdRunOptions o;
  o.cycles = std::max(1, options.cycles);
  const int run = ++runs_;
  if (log_)
    *log_ << fmt::format("cfd model: run {} ({} wingbeats), body velocity ({:.4g}, {:.4g}, {:.4g}) m/s, rates "
                         "({:.4g}, {:.4g}, {:.4g}) rad/s ...\n",
                         run, o.cycles, motion.velocity.x(), motion.velocity.y(), motion.velocity.z(),
                         motion.rate.x(), motion.rate.y(), motion.rate.z())
          << std::flush;
  const auto t0 = std::chrono::steady_clock::now();
  const CfdResult r = run_cfd(c, kin, motion, o);
  if (log_)
    *log_ << fmt::format("cfd model: run {} done in {:.1f} s\n", run,
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count())
          << std::flush;
  const double T = r.plan.period, start = (r.plan.cycles - 1) * T;
  if (r.last_cycle.empty() || r.last_cycle.back().time - start < 1e-9 * T)
    throw SolveError("cfd model: the run produced no loads");
  // Phase times of the last wingbeat's rows in (0, T], extended periodically, resampled equally spaced.
  std::vector<std::pair<double, WrenchSample>> pts;
  for (const auto& row : r.last_cycle) {
    if (row.time - start < 1e-9 * T) continue;  // the wingbeat's start row: the same phase as its end
    WrenchSample w;
    const auto wr = [&](int i) {
      const auto& q = row.part[i];
      return Wrench{q.pressure_force + q.viscous_force, q.pressure_moment + q.viscous_moment};
    };
    w.body = wr(0);
    w.right = wr(1);
    w.left = wr(2);
    w.power = row.wing_power;
    pts.emplace_back(row.time - start, w);
  }
  const int n = options.samples_per_cycle > 0 ? options.samples_per_cycle
                : r.plan.steps_per_cycle > 0   ? r.plan.steps_per_cycle
                                               : 64;
  auto lerp = [](const WrenchSample& a, const WrenchSample& b, double f) {
    WrenchSample w;
    w.body = (1 - f) * a.body + f * b.body;
    w.right = (1 - f) * a.right + f * b.right;
    w.left = (1 - f) * a.left + f * b.left;
    w.power = (1 - f) * a.power + f * b.power;
    return w;
  };
  WrenchHistory h;
  for (int j = 0; j < n; ++j) {
    const double tau = T * j / n;
    // Bracket tau among the points, the last one carried back by a period before the first.
    std::pair<double, WrenchSample> lo{pts.back().first - T, pts.back().second}, hi = pts.front();
    for (std::size_t k = 0; k < pts.size(); ++k) {
      if (pts[k].first >= tau - 1e-12 * T) {
        hi = pts[k];
        if (k > 0) lo = pts[k - 1];
        break;
      }
      lo = pts[k];
      hi = {pts.front().first + T, pts.front().second};
    }
    const double f = hi.first > lo.first ? (tau - lo.first) / (hi.first - lo.first) : 1.0;
    WrenchSample w = lerp(lo.second, hi.second, std::clamp(f, 0.0, 1.0));
    w.time = tau;
    h.samples.push_back(w);
  }
  return h;
}

}  // namespace flapstab::ns
