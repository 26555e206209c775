// Trim refinement by Broyden's method (refine.hpp).
#include "trim/refine.hpp"

#include <algorithm>
#include <cmath>
#include <ostream>
#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/errors.hpp"
#include "trim/parameters.hpp"

namespace flapstab {

namespace {

Eigen::VectorXd residual(const Case& c, const Wrench& mean, const std::vector<std::string>& eq) {
  const double W = c.insect.weight(), WR = W * c.insect.wing.length;
  Eigen::VectorXd r = Eigen::VectorXd::Zero(Eigen::Index(eq.size()));
  for (std::size_t i = 0; i < eq.size(); ++i) {
    const char e = eq[i][0];
    const Eigen::Index k = Eigen::Index(i);
    if (e == 'X') r(k) = mean.force.x() / W;
    else if (e == 'Y') r(k) = mean.force.y() / W;
    else if (e == 'Z') r(k) = (mean.force.z() + W) / W;
    else if (e == 'L') r(k) = mean.moment.x() / WR;
    else if (e == 'M') r(k) = mean.moment.y() / WR;
    else r(k) = mean.moment.z() / WR;
  }
  return r;
}

}  // namespace

TrimResult refine_trim(const Case& c, const AeroModel& model, const AeroModel& start_model, const TrimResult& start,
                       const RefineSettings& s, std::ostream* log) {
  const auto& specs = c.trim.parameters;
  const TrimParameterization par(c.kinematics, specs, c.path);
  const std::size_t n = specs.size();
  if (start.parameters.size() != n) throw SolveError("refine_trim: the starting trim has other parameters");
  const Eigen::Index nn = Eigen::Index(n);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(nn), lo = x, hi = x, h = x;
  for (std::size_t i = 0; i < n; ++i) {
    x(Eigen::Index(i)) = start.parameters[i].value;
    lo(Eigen::Index(i)) = specs[i].lower;
    hi(Eigen::Index(i)) = specs[i].upper;
    h(Eigen::Index(i)) = 0.01 * (specs[i].upper - specs[i].lower);  // difference step: 1 % of the bounds' range
  }
  auto values = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  auto mean_of = [&](const AeroModel& m, const Eigen::VectorXd& v, double* power = nullptr) {
    const WrenchHistory hist = m.run(c.insect, par.apply(values(v)), BodyMotion{}, AeroRunOptions{});
    if (power) *power = hist.mean_power();
    return hist.mean();
  };
  const auto& eq = start.equations;
  // First Jacobian: central differences of the starting model.
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(Eigen::Index(eq.size()), nn);
  for (std::size_t j = 0; j < n; ++j) {
    Eigen::VectorXd xp = x, xm = x;
    xp(Eigen::Index(j)) += h(Eigen::Index(j));
    xm(Eigen::Index(j)) -= h(Eigen::Index(j));
    J.col(Eigen::Index(j)) = (residual(c, mean_of(start_model, xp), eq) - residual(c, mean_of(start_model, xm), eq)) /
                             (2 * h(Eigen::Index(j)));
  }
  TrimResult res = start;
  res.solver = "broyden";
  res.objective = "residual";
  res.model_runs = 0;
  double power = 0;
  Wrench mean = mean_of(model, x, &power);
  ++res.model_runs;
  Eigen::VectorXd r = residual(c, mean, eq);
  int it = 0;
  auto report = [&] {
    if (!log) return;
    std::string p, q;
    for (std::size_t i = 0; i < n; ++i) p += fmt::format(" {}={:.4f}", specs[i].label(), x(Eigen::Index(i)));
    for (std::size_t i = 0; i < eq.size(); ++i) q += fmt::format(" {}={:+.3e}", eq[i], r(Eigen::Index(i)));
    *log << fmt::format("trim on {}: iteration {}:{}; residuals{}\n", model.name(), it, p, q) << std::flush;
  };
  report();
  while (r.cwiseAbs().maxCoeff() > s.tolerance && it < s.max_iterations) {
    Eigen::VectorXd dx = J.completeOrthogonalDecomposition().solve(-r);
    // Trust region: at most a quarter of each parameter's bound range per iteration.
    double scale = 1;
    for (Eigen::Index i = 0; i < nn; ++i) scale = std::max(scale, std::abs(dx(i)) / (0.25 * (hi(i) - lo(i))));
    dx /= scale;
    const Eigen::VectorXd xn = (x + dx).cwiseMax(lo).cwiseMin(hi);
    dx = xn - x;
    if (dx.norm() == 0) break;  // held at a bound
    double pw = 0;
    const Wrench mn = mean_of(model, xn, &pw);
    ++res.model_runs;
    const Eigen::VectorXd rn = residual(c, mn, eq);
    J += (rn - r - J * dx) * dx.transpose() / dx.squaredNorm();
    x = xn;
    r = rn;
    mean = mn;
    power = pw;
    ++it;
    report();
  }
  res.iterations = it;
  res.kinematics = par.apply(values(x));
  for (std::size_t i = 0; i < n; ++i) {
    res.parameters[i].initial = start.parameters[i].value;
    res.parameters[i].value = x(Eigen::Index(i));
  }
  res.force_residual = mean.force + Vec3(0, 0, res.weight);
  res.moment_residual = mean.moment;
  res.relative_force_residual = res.force_residual.norm() / res.weight;
  res.relative_moment_residual = res.moment_residual.norm() / (res.weight * c.insect.wing.length);
  res.mean_power = power;
  res.converged = r.cwiseAbs().maxCoeff() <= s.tolerance;
  res.message = fmt::format("{} after {} iteration(s) from the {} trim (largest residual {:.3e}, tolerance {:g})",
                            res.converged ? "converged" : "not converged", it, start.solver, r.cwiseAbs().maxCoeff(),
                            s.tolerance);
  return res;
}

std::vector<Kinematics> trim_extreme_kinematics(const Case& c, const TrimResult& start) {
  const TrimParameterization par(c.kinematics, c.trim.parameters, c.path);
  std::vector<double> x;
  for (const auto& p : start.parameters) x.push_back(p.value);
  std::vector<Kinematics> out{par.apply(x)};
  for (std::size_t i = 0; i < x.size(); ++i)
    for (double b : {c.trim.parameters[i].lower, c.trim.parameters[i].upper}) {
      std::vector<double> y = x;
      y[i] = b;
      out.push_back(par.apply(y));
    }
  return out;
}

}  // namespace flapstab
