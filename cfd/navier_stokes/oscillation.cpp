// Forced pitch oscillation of the hovering insect (oscillation.hpp).
#include "cfd/navier_stokes/oscillation.hpp"

#include <cmath>
#include <numbers>
#include <fmt/format.h>
#include "core/errors.hpp"

namespace flapstab::ns {

PitchAngle pitch_oscillation_angle(const PitchOscillationSpec& spec, double T, double tau) {
  const double w = 2 * std::numbers::pi / (spec.period_wingbeats * T);
  const double s = std::sin(w * tau), c = std::cos(w * tau);
  return {spec.amplitude * s, spec.amplitude * w * c, -spec.amplitude * w * w * s};
}

OscillationFit fit_oscillation(const std::vector<double>& theta, const std::vector<double>& rate,
                               const std::vector<double>& y) {
  const std::size_t m = y.size();
  if (theta.size() != m || rate.size() != m || m < 3)
    throw SolveError("pitch oscillation: a fit needs at least three wingbeats with theta, q and the load");
  const Eigen::Index rows = Eigen::Index(m);
  Eigen::MatrixXd X(rows, 3);
  Eigen::VectorXd Y(rows);
  for (std::size_t k = 0; k < m; ++k) {
    X(Eigen::Index(k), 0) = theta[k];
    X(Eigen::Index(k), 1) = rate[k];
    X(Eigen::Index(k), 2) = 1;
    Y(Eigen::Index(k)) = y[k];
  }
  // Columns scaled to unit norm first: theta (rad) and q (rad/s) differ by orders of magnitude.
  const Eigen::Vector3d scale = X.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd Xs = X * scale.cwiseInverse().asDiagonal();
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Xs);
  if (qr.rank() < 3) throw SolveError("pitch oscillation: theta, q and a constant are not independent over the fit");
  const Eigen::Vector3d beta = qr.solve(Y).cwiseQuotient(scale);
  OscillationFit f;
  f.theta = beta(0);
  f.rate = beta(1);
  f.constant = beta(2);
  const Eigen::VectorXd res = Y - X * beta;
  f.rms = std::sqrt(res.squaredNorm() / double(m));
  if (m >= 4) {
    const double s2 = res.squaredNorm() / double(m - 3);
    const Eigen::Matrix3d cov = s2 * (X.transpose() * X).inverse();
    f.theta_se = std::sqrt(cov(0, 0));
    f.rate_se = std::sqrt(cov(1, 1));
  }
  return f;
}

void fit_pitch_oscillation(PitchOscillationResult& r) {
  const int first = r.spec.transient(), P = r.spec.period_wingbeats;
  const int n = int(r.wingbeats.size());
  if (n < first + P)
    throw SolveError(
        fmt::format("pitch oscillation: {} wingbeats, fewer than the transient ({}) and one period ({})", n, first, P));
  auto fit = [&](int from, int to, int component) {  // wingbeats from+1 .. to (1-based)
    std::vector<double> th, q, y;
    for (int k = from; k < to; ++k) {
      const OscillationWingbeat& w = r.wingbeats[std::size_t(k)];
      th.push_back(w.theta);
      q.push_back(w.rate);
      y.push_back(component < 3 ? w.difference.force[component] : w.difference.moment[component - 3]);
    }
    return fit_oscillation(th, q, y);
  };
  for (int c = 0; c < 6; ++c) {
    r.fit[std::size_t(c)] = fit(first, n, c);
    r.last_period[std::size_t(c)] = fit(n - P, n, c);
  }
  // Per phase: the fitted wingbeats' differences at step i against theta and q at that step's time,
  // tau = ((k - 1) n + i + 1) T / n in wingbeat k (T = 2 pi / (omega P)).
  r.phase.clear();
  r.phase_note.clear();
  const std::size_t steps = r.wingbeats[std::size_t(first)].steps.size();
  for (int k = first; k < n; ++k)
    if (r.wingbeats[std::size_t(k)].steps.size() != steps || steps == 0) {
      r.phase_note = "the run's wingbeats hold no per-step differences (kept by an earlier flapstab; delete the run's "
                     "pitch_KEY.json and .h5 from the run cache to make it again with them)";
      return;
    }
  const double T = 2 * std::numbers::pi / (r.omega * P);
  const int m = int(steps);
  for (int i = 0; i < m; ++i) {
    std::vector<double> th, q;
    std::array<std::vector<double>, 6> y;
    for (int k = first; k < n; ++k) {
      const PitchAngle a = pitch_oscillation_angle(r.spec, T, (double(k) * m + i + 1) * T / m);
      th.push_back(a.theta);
      q.push_back(a.rate);
      const Wrench& d = r.wingbeats[std::size_t(k)].steps[std::size_t(i)];
      for (int c = 0; c < 6; ++c) y[std::size_t(c)].push_back(c < 3 ? d.force[c] : d.moment[c - 3]);
    }
    std::array<OscillationFit, 6> at;
    try {
      for (std::size_t c = 0; c < 6; ++c) at[c] = fit_oscillation(th, q, y[c]);
    } catch (const SolveError& e) {  // theta, q and a constant dependent at one phase (not expected for P >= 3)
      r.phase.clear();
      r.phase_note = fmt::format("at phase step {}: {}", i + 1, e.what());
      return;
    }
    r.phase.push_back(at);
  }
}

}  // namespace flapstab::ns
