// Delay systems: generator collocation + Newton for characteristic roots, delay margins, Floquet with delay.
#include "stability/delayed_feedback.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <map>

#include "core/errors.hpp"
#include "core/types.hpp"

namespace flapstab {

namespace {

using cplx = std::complex<double>;
constexpr double inf = std::numeric_limits<double>::infinity();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

void require(bool ok, const std::string& key, const std::string& problem, const std::string& expected) {
  if (!ok) throw InputError("", key, problem, expected);
}

void check_system(const DelaySystem& s) {
  const Eigen::Index n = s.A.rows();
  require(n > 0 && s.A.cols() == n, "A", fmt::format("is {} x {}", s.A.rows(), s.A.cols()), "a square, non-empty matrix");
  require(s.A.allFinite(), "A", "has a non-finite entry", "finite entries");
  for (std::size_t j = 0; j < s.delayed.size(); ++j) {
    const DelayTerm& d = s.delayed[j];
    const std::string key = fmt::format("delayed[{}]", j);
    require(d.B.rows() == n && d.B.cols() == n, key + ".B", fmt::format("is {} x {}", d.B.rows(), d.B.cols()),
            fmt::format("{} x {} like A", n, n));
    require(d.B.allFinite(), key + ".B", "has a non-finite entry", "finite entries");
    require(std::isfinite(d.tau) && d.tau >= 0, key + ".tau", fmt::format("latency {} is not usable", d.tau),
            "a finite latency >= 0");
  }
}

void check_options(const DelayRootsOptions& o) {
  require(o.nodes >= 2, "nodes", fmt::format("is {}", o.nodes), "at least 2");
  require(o.max_nodes >= 2, "max_nodes", fmt::format("is {}", o.max_nodes), "at least 2");
  require(o.roots >= 1, "roots", fmt::format("is {}", o.roots), "at least 1");
  require(std::isfinite(o.tolerance) && o.tolerance > 0, "tolerance", fmt::format("is {}", o.tolerance), "> 0");
}

// Orthonormal rows spanning the rows of all given n-column matrices (singular values above 1e-12 of the largest).
Eigen::MatrixXd row_space(const std::vector<const Eigen::MatrixXd*>& Bs, Eigen::Index n) {
  Eigen::Index rows = 0;
  for (const auto* B : Bs) rows += B->rows();
  if (rows == 0) return Eigen::MatrixXd(0, n);
  Eigen::MatrixXd S(rows, n);
  Eigen::Index at = 0;
  for (const auto* B : Bs) {
    S.middleRows(at, B->rows()) = *B;
    at += B->rows();
  }
  // R of a QR has the row space of S in n x n, so the SVD stays small however many samples are stacked.
  const Eigen::MatrixXd R = S.householderQr().matrixQR().topRows(std::min(rows, n)).triangularView<Eigen::Upper>();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(R, Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  Eigen::Index r = 0;
  while (r < sv.size() && sv(r) > 1e-12 * sv(0)) ++r;
  return svd.matrixV().leftCols(r).transpose();
}

// Delta(lambda) = lambda I - A - sum_j B_j e^(-lambda tau_j).
Eigen::MatrixXcd characteristic_matrix(const DelaySystem& s, cplx lambda) {
  const Eigen::Index n = s.A.rows();
  Eigen::MatrixXcd D = lambda * Eigen::MatrixXcd::Identity(n, n) - s.A.cast<cplx>();
  for (const DelayTerm& d : s.delayed) D -= std::exp(-lambda * d.tau) * d.B.cast<cplx>();
  return D;
}

// d Delta / d lambda = I + sum_j tau_j B_j e^(-lambda tau_j).
Eigen::MatrixXcd characteristic_derivative(const DelaySystem& s, cplx lambda) {
  const Eigen::Index n = s.A.rows();
  Eigen::MatrixXcd D = Eigen::MatrixXcd::Identity(n, n);
  for (const DelayTerm& d : s.delayed) D += (d.tau * std::exp(-lambda * d.tau)) * d.B.cast<cplx>();
  return D;
}

// sigma_min(Delta(lambda)) relative to the size of its terms (Frobenius norms).
double scaled_residual(const DelaySystem& s, cplx lambda) {
  double scale = std::abs(lambda) + s.A.norm();
  for (const DelayTerm& d : s.delayed) scale += d.B.norm() * std::exp(-lambda.real() * d.tau);
  const Eigen::JacobiSVD<Eigen::MatrixXcd> svd(characteristic_matrix(s, lambda));
  return svd.singularValues().minCoeff() / scale;
}

struct Refined {
  cplx lambda;
  bool accepted = false;
};

// Newton on det Delta(lambda) = 0: lambda <- lambda - 1 / tr(Delta^-1 Delta') (Jacobi's formula
// d/dlambda log det Delta = tr(Delta^-1 Delta')). Rejected when it does not converge in 50 steps or moves
// further than 10 % of (|lambda_0| + 1 / tau_max) from its start (a spurious eigenvalue of the discretisation).
Refined newton_root(const DelaySystem& s, cplx start, double scale) {
  const double reach = 0.1 * (std::abs(start) + scale);
  Refined r;
  r.lambda = start;
  bool converged = false;
  for (int it = 0; it < 50 && !converged; ++it) {
    const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(characteristic_matrix(s, r.lambda));
    const cplx step = 1.0 / lu.solve(characteristic_derivative(s, r.lambda)).trace();
    if (!std::isfinite(step.real()) || !std::isfinite(step.imag())) break;  // singular Delta: judged by the residual
    r.lambda -= step;
    if (std::abs(r.lambda - start) > reach) return r;
    converged = std::abs(step) <= 1e-13 * (std::abs(r.lambda) + scale);
  }
  r.accepted = converged || scaled_residual(s, r.lambda) < 1e-13;
  return r;
}

// The system with its zero-delay terms folded into A and the history reduced to the row space of the delayed B's.
struct Reduced {
  Eigen::Index n = 0;
  Eigen::MatrixXd A0;               // A + sum of the B_j with tau_j = 0
  std::vector<double> tau;          // the positive delays
  std::vector<Eigen::MatrixXd> Bt;  // B_j C^T, n x r
  Eigen::MatrixXd C;                // r x n, orthonormal rows
  double tau_max = 0;
};

Reduced reduce(const DelaySystem& s) {
  Reduced red;
  red.n = s.A.rows();
  red.A0 = s.A;
  std::vector<const Eigen::MatrixXd*> Bs;
  for (const DelayTerm& d : s.delayed) {
    if (d.tau == 0) {
      red.A0 += d.B;
    } else if (d.B.cwiseAbs().maxCoeff() > 0) {
      Bs.push_back(&d.B);
      red.tau.push_back(d.tau);
      red.tau_max = std::max(red.tau_max, d.tau);
    }
  }
  red.C = row_space(Bs, red.n);
  for (const auto* B : Bs) red.Bt.push_back(*B * red.C.transpose());
  return red;
}

// Chebyshev points theta_i = (tau/2)(cos(i pi / N) - 1), i = 0..N, and the differentiation matrix on them
// (Trefethen 2000, Spectral Methods in MATLAB, cheb.m; diagonal by the negative-sum trick).
Eigen::MatrixXd chebyshev_differentiation(int N, double tau, Eigen::VectorXd& theta) {
  theta.resize(N + 1);
  Eigen::VectorXd x(N + 1), c(N + 1);
  for (int i = 0; i <= N; ++i) {
    x(i) = std::cos(pi * i / N);
    theta(i) = 0.5 * tau * (x(i) - 1);
    c(i) = ((i == 0 || i == N) ? 2.0 : 1.0) * ((i % 2) ? -1.0 : 1.0);
  }
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(N + 1, N + 1);
  for (int i = 0; i <= N; ++i) {
    for (int j = 0; j <= N; ++j)
      if (i != j) D(i, j) = (c(i) / c(j)) / (x(i) - x(j));
    D(i, i) = -D.row(i).sum();
  }
  return D * (2.0 / tau);
}

// Barycentric Lagrange weights l_i(t) of the Chebyshev points theta (Berrut & Trefethen 2004, SIAM Rev 46:501).
Eigen::VectorXd lagrange_weights(const Eigen::VectorXd& theta, double t) {
  const Eigen::Index m = theta.size();
  Eigen::VectorXd l(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    if (t == theta(i)) {
      l.setZero();
      l(i) = 1;
      return l;
    }
    const double w = ((i == 0 || i == m - 1) ? 0.5 : 1.0) * ((i % 2) ? -1.0 : 1.0);
    l(i) = w / (t - theta(i));
  }
  return l / l.sum();
}

// Collocation of the infinitesimal generator on N + 1 Chebyshev points of [-tau_max, 0] (Breda, Maset &
// Vermiglio 2005), history reduced to y = C x: unknowns x(0) (n) and y(theta_i), i = 1..N (r each).
//   x(0)' = A0 x(0) + sum_j Bt_j [l_0(-tau_j) C x(0) + sum_i l_i(-tau_j) y_i]
//   y_i'  = D_i0 C x(0) + sum_k D_ik y_k
Eigen::MatrixXd generator_matrix(const Reduced& red, int N) {
  const Eigen::Index n = red.n, r = red.C.rows();
  Eigen::VectorXd theta;
  const Eigen::MatrixXd D = chebyshev_differentiation(N, red.tau_max, theta);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n + r * N, n + r * N);
  G.topLeftCorner(n, n) = red.A0;
  for (std::size_t j = 0; j < red.tau.size(); ++j) {
    const Eigen::VectorXd l = lagrange_weights(theta, -red.tau[j]);
    G.topLeftCorner(n, n) += l(0) * red.Bt[j] * red.C;
    for (int i = 1; i <= N; ++i) G.block(0, n + (i - 1) * r, n, r) += l(i) * red.Bt[j];
  }
  for (int i = 1; i <= N; ++i) {
    G.block(n + (i - 1) * r, 0, r, n) = D(i, 0) * red.C;
    for (int k = 1; k <= N; ++k) G.block(n + (i - 1) * r, n + (k - 1) * r, r, r).diagonal().setConstant(D(i, k));
  }
  return G;
}

bool rightmost_first(cplx a, cplx b) { return a.real() != b.real() ? a.real() > b.real() : a.imag() > b.imag(); }

using RootSet = std::vector<cplx>;  // accepted roots, rightmost first

// One discretisation: the rightmost `wanted` + 4 eigenvalues of the generator matrix are refined (upper
// half-plane only; the lower one is their mirror image, the system being real), duplicates merged.
RootSet roots_at(const DelaySystem& s, const Reduced& red, int N, int wanted) {
  const Eigen::MatrixXd G = generator_matrix(red, N);
  const Eigen::EigenSolver<Eigen::MatrixXd> es(G, false);
  if (es.info() != Eigen::Success) throw SolveError(fmt::format("delay roots: eigenvalues of the {}-node collocation failed", N));
  std::vector<cplx> ev(es.eigenvalues().data(), es.eigenvalues().data() + es.eigenvalues().size());
  std::sort(ev.begin(), ev.end(), rightmost_first);
  const std::size_t candidates = std::min(ev.size(), std::size_t(wanted + 4));
  const double scale = 1.0 / red.tau_max;
  RootSet set;
  auto add = [&](cplx z) {
    for (const cplx& w : set)
      if (std::abs(z - w) <= 1e-8 * (std::abs(z) + scale)) return;
    set.push_back(z);
  };
  for (std::size_t k = 0; k < candidates; ++k) {
    if (ev[k].imag() < 0) continue;
    Refined r = newton_root(s, ev[k], scale);
    if (!r.accepted) continue;
    if (std::abs(r.lambda.imag()) <= 1e-12 * (std::abs(r.lambda) + scale)) r.lambda.imag(0);
    add(r.lambda);
    if (r.lambda.imag() != 0) add(std::conj(r.lambda));
  }
  std::sort(set.begin(), set.end(), rightmost_first);
  return set;
}

// Max over the first `count` roots of each set of the relative distance to the nearest root of the other set.
double set_change(const RootSet& a, const RootSet& b, std::size_t count, double scale) {
  if (a.empty() || b.empty()) return inf;
  double change = 0;
  for (int pass = 0; pass < 2; ++pass) {
    const RootSet& p = pass ? b : a;
    const RootSet& q = pass ? a : b;
    for (std::size_t i = 0; i < std::min(count, p.size()); ++i) {
      double best = inf;
      for (const cplx& z : q) best = std::min(best, std::abs(p[i] - z));
      change = std::max(change, best / std::max(std::abs(p[i]), scale));
    }
  }
  return change;
}

// The rightmost `wanted` roots with their residuals (one singular value decomposition per conjugate pair).
DelayRoots finish(const DelaySystem& s, const RootSet& set, int wanted) {
  DelayRoots out;
  const std::size_t k = std::min(set.size(), std::size_t(wanted));
  out.roots.assign(set.begin(), set.begin() + std::ptrdiff_t(k));
  for (std::size_t i = 0; i < k; ++i)
    out.residuals.push_back(i > 0 && out.roots[i] == std::conj(out.roots[i - 1]) ? out.residuals.back()
                                                                                 : scaled_residual(s, out.roots[i]));
  return out;
}

}  // namespace

double DelayRoots::spectral_abscissa() const {
  double a = -inf;
  for (const cplx& z : roots) a = std::max(a, z.real());
  return roots.empty() ? nan : a;
}

// Breda, Maset & Vermiglio 2005 (collocation of the generator) + Newton on det Delta, N grown by 50 %.
DelayRoots rightmost_roots(const DelaySystem& system, const DelayRootsOptions& options) {
  check_system(system);
  check_options(options);
  const Reduced red = reduce(system);
  if (red.C.rows() == 0) {
    // No delayed term left: the eigenvalues of A + sum of the zero-delay B's are the characteristic roots.
    const Eigen::EigenSolver<Eigen::MatrixXd> es(red.A0, false);
    if (es.info() != Eigen::Success) throw SolveError("delay roots: eigenvalues of A failed");
    std::vector<cplx> ev(es.eigenvalues().data(), es.eigenvalues().data() + es.eigenvalues().size());
    std::sort(ev.begin(), ev.end(), rightmost_first);
    DelayRoots out = finish(system, ev, options.roots);
    out.nodes = 0;
    out.discretisation_change = 0;
    out.converged = true;
    return out;
  }
  int N = options.nodes;
  RootSet coarse = roots_at(system, red, N, options.roots);
  if (coarse.empty()) throw SolveError(fmt::format("delay roots: no candidate of the {}-node collocation converged", N));
  if (!options.check_convergence) {
    DelayRoots out = finish(system, coarse, options.roots);
    out.nodes = N;
    return out;
  }
  double change = nan;
  while (N < options.max_nodes) {
    const int N2 = std::min(options.max_nodes, (3 * N + 1) / 2);
    RootSet fine = roots_at(system, red, N2, options.roots);
    change = set_change(coarse, fine, std::size_t(options.roots), 1.0 / red.tau_max);
    if (change <= options.tolerance) {
      DelayRoots out = finish(system, fine, options.roots);
      out.nodes = N;
      out.discretisation_change = change;
      out.converged = true;
      return out;
    }
    coarse = std::move(fine);
    N = N2;
  }
  DelayRoots out = finish(system, coarse, options.roots);
  out.nodes = N;
  out.discretisation_change = change;
  return out;
}

namespace {

void check_latency_max(double latency_max) {
  require(std::isfinite(latency_max) && latency_max > 0, "latency_max", fmt::format("is {}", latency_max),
          "a finite latency > 0");
}

// Options with the discretisation verified at the given (gain, latency) corners: check_convergence off and
// nodes = the largest accepted N. converged reports whether every corner passed.
DelayRootsOptions verified_options(const DelaySystemBuilder& build, const std::vector<double>& gains,
                                   double latency, const DelayRootsOptions& options, bool& converged) {
  DelayRootsOptions o = options;
  converged = true;
  if (!options.check_convergence) {
    converged = false;
    return o;
  }
  int nodes = options.nodes;
  for (double g : gains) {
    const DelayRoots r = rightmost_roots(build(g, latency), options);
    converged = converged && r.converged;
    nodes = std::max(nodes, r.nodes);
  }
  o.nodes = nodes;
  o.check_convergence = false;
  return o;
}

double abscissa_at(const DelaySystemBuilder& build, double gain, double latency, const DelayRootsOptions& o) {
  return rightmost_roots(build(gain, latency), o).spectral_abscissa();
}

// d Delta(lambda; tau) / d tau by central differences of the builder (forward at tau < h).
Eigen::MatrixXcd characteristic_dtau(const DelaySystemBuilder& build, double gain, double tau, cplx lambda, double h) {
  const double lo = std::max(0.0, tau - h), hi = tau + h;
  return (characteristic_matrix(build(gain, hi), lambda) - characteristic_matrix(build(gain, lo), lambda)) / (hi - lo);
}

// Newton on det Delta(i omega; tau) = 0 for real (omega, tau): with t_w = tr(Delta^-1 dDelta/domega),
// t_t = tr(Delta^-1 dDelta/dtau), the step solves t_w d_omega + t_t d_tau = -1 (real and imaginary parts).
// omega = 0 solves the real equation det Delta(0; tau) = 0 for tau alone. False when it does not converge.
bool refine_crossing(const DelaySystemBuilder& build, double gain, double latency_max, double& omega, double& tau) {
  const bool real_crossing = omega == 0;
  for (int it = 0; it < 60; ++it) {
    const DelaySystem s = build(gain, tau);
    const cplx lambda(0, omega);
    const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(characteristic_matrix(s, lambda));
    const double h = 1e-6 * std::max(tau, 1e-3 * latency_max);
    const cplx tt = lu.solve(characteristic_dtau(build, gain, tau, lambda, h)).trace();
    double dw = 0, dt = 0;
    if (real_crossing) {
      dt = -1.0 / tt.real();
    } else {
      const cplx tw = cplx(0, 1) * lu.solve(characteristic_derivative(s, lambda)).trace();
      Eigen::Matrix2d J;
      J << tw.real(), tt.real(), tw.imag(), tt.imag();
      const Eigen::Vector2d d = J.fullPivLu().solve(Eigen::Vector2d(-1, 0));
      dw = d(0);
      dt = d(1);
    }
    if (!std::isfinite(dw) || !std::isfinite(dt)) return false;
    omega += dw;
    tau += dt;
    if (!(tau >= 0) || tau > 2 * latency_max) return false;
    if (std::abs(dt) <= 1e-13 * std::max(tau, 1e-3 * latency_max) &&
        std::abs(dw) <= 1e-13 * std::max(std::abs(omega), 1.0 / std::max(tau, 1e-3 * latency_max)))
      return true;
  }
  return false;
}

CriticalLatency critical_latency_with(const DelaySystemBuilder& build, double gain, double latency_max,
                                      const DelayRootsOptions& o) {
  constexpr int scan = 64;
  CriticalLatency c;
  c.gain = gain;
  double a_prev = abscissa_at(build, gain, 0, o);
  c.stable_without_delay = a_prev < 0;
  if (!c.stable_without_delay) return c;
  double t_prev = 0;
  for (int k = 1; k <= scan; ++k) {
    const double t = latency_max * k / scan;
    const DelayRoots r = rightmost_roots(build(gain, t), o);
    const double a = r.spectral_abscissa();
    if (a < 0) {
      a_prev = a;
      t_prev = t;
      continue;
    }
    // First sign change in [t_prev, t]: Newton from the linear interpolation of the abscissa.
    double tau = t_prev + (t - t_prev) * (-a_prev) / (a - a_prev);
    double omega = std::abs(r.roots.front().imag());
    if (refine_crossing(build, gain, latency_max, omega, tau) && tau >= t_prev - 1e-9 * t && tau <= t * (1 + 1e-9)) {
      c.latency = tau;
      c.crossing_frequency = std::abs(omega);
      return c;
    }
    // Newton failed or left the step: bisection on the abscissa, to 1e-12 relative.
    double lo = t_prev, hi = t;
    DelayRoots at_hi = r;
    while (hi - lo > 1e-12 * hi) {
      const double mid = 0.5 * (lo + hi);
      DelayRoots m = rightmost_roots(build(gain, mid), o);
      if (m.spectral_abscissa() < 0) {
        lo = mid;
      } else {
        hi = mid;
        at_hi = std::move(m);
      }
    }
    c.latency = hi;
    c.crossing_frequency = std::abs(at_hi.roots.front().imag());
    return c;
  }
  c.latency = inf;
  return c;
}

}  // namespace

// Spectral abscissa of build(g, tau) on the grid, with one discretisation verified at the largest latency.
StabilityMap stability_map(const DelaySystemBuilder& build, const std::vector<double>& gains,
                           const std::vector<double>& latencies, const DelayRootsOptions& options) {
  require(!gains.empty(), "gains", "is empty", "at least one gain");
  require(!latencies.empty(), "latencies", "is empty", "at least one latency");
  for (double t : latencies) require(std::isfinite(t) && t >= 0, "latencies", fmt::format("has {}", t), "finite latencies >= 0");
  check_options(options);
  StabilityMap map;
  map.gains = gains;
  map.latencies = latencies;
  const double tmax = *std::max_element(latencies.begin(), latencies.end());
  const DelayRootsOptions o = verified_options(build, {gains.front(), gains.back()}, tmax, options, map.converged);
  map.nodes = o.nodes;
  map.abscissa.resize(Eigen::Index(gains.size()), Eigen::Index(latencies.size()));
  for (std::size_t i = 0; i < gains.size(); ++i)
    for (std::size_t j = 0; j < latencies.size(); ++j)
      map.abscissa(Eigen::Index(i), Eigen::Index(j)) = abscissa_at(build, gains[i], latencies[j], o);
  return map;
}

// Delay margin: scan of the spectral abscissa, then Newton on det Delta(i omega; tau) = 0 for (omega, tau).
CriticalLatency critical_latency(const DelaySystemBuilder& build, double gain, double latency_max,
                                 const DelayRootsOptions& options) {
  require(std::isfinite(gain), "gain", fmt::format("is {}", gain), "a finite gain");
  check_latency_max(latency_max);
  check_options(options);
  bool converged = false;
  const DelayRootsOptions o = verified_options(build, {gain}, latency_max, options, converged);
  return critical_latency_with(build, gain, latency_max, o);
}

// Largest critical latency over [gmin, gmax]: 17-point scan, then golden-section search (Kiefer 1953).
CriticalLatency best_gain(const DelaySystemBuilder& build, double gmin, double gmax, double latency_max,
                          const DelayRootsOptions& options) {
  require(std::isfinite(gmin) && std::isfinite(gmax) && gmin < gmax, "gmin",
          fmt::format("[{}, {}] is not a gain interval", gmin, gmax), "finite gmin < gmax");
  check_latency_max(latency_max);
  check_options(options);
  bool converged = false;
  const DelayRootsOptions o = verified_options(build, {gmin, gmax}, latency_max, options, converged);
  auto value = [](const CriticalLatency& c) { return c.stable_without_delay ? c.latency : -1.0; };
  constexpr int scan = 16;
  std::vector<CriticalLatency> cs;
  for (int k = 0; k <= scan; ++k) cs.push_back(critical_latency_with(build, gmin + (gmax - gmin) * k / scan, latency_max, o));
  // Widest run of gains stable on all of [0, latency_max]: its middle, unrefined.
  int best_run = 0, best_mid = -1;
  for (int k = 0; k <= scan;) {
    int e = k;
    while (e <= scan && value(cs[std::size_t(e)]) == inf) ++e;
    if (e - k > best_run) {
      best_run = e - k;
      best_mid = (k + e - 1) / 2;
    }
    k = std::max(e, k + 1);
  }
  if (best_mid >= 0) return cs[std::size_t(best_mid)];
  std::size_t b = 0;
  for (std::size_t k = 1; k < cs.size(); ++k)
    if (value(cs[k]) > value(cs[b])) b = k;
  if (!cs[b].stable_without_delay) {
    CriticalLatency none;
    return none;  // no gain of the scan is stable at latency 0
  }
  double lo = cs[b == 0 ? 0 : b - 1].gain, hi = cs[std::min(b + 1, cs.size() - 1)].gain;
  const double phi = 0.5 * (std::sqrt(5.0) - 1);
  CriticalLatency best = cs[b];
  auto eval = [&](double g) {
    CriticalLatency c = critical_latency_with(build, g, latency_max, o);
    if (value(c) > value(best)) best = c;
    return value(c);
  };
  double x1 = hi - phi * (hi - lo), x2 = lo + phi * (hi - lo);
  double f1 = eval(x1), f2 = eval(x2);
  while (hi - lo > 1e-6 * (gmax - gmin)) {
    if (f1 >= f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - phi * (hi - lo);
      f1 = eval(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + phi * (hi - lo);
      f2 = eval(x2);
    }
  }
  return best;
}

double DelayFloquet::spectral_radius() const { return multipliers.empty() ? nan : std::abs(multipliers.front()); }

namespace {

void check_periodic(const PeriodicDelaySystem& s, const DelayFloquetOptions& o) {
  require(std::isfinite(s.period) && s.period > 0, "period", fmt::format("is {}", s.period), "a finite period > 0");
  require(s.n > 0, "n", fmt::format("is {}", s.n), "at least 1 state");
  require(bool(s.A), "A", "is not set", "a function of t");
  require(s.B.size() == s.tau.size(), "tau", fmt::format("has {} latencies for {} delayed terms", s.tau.size(), s.B.size()),
          "one latency per B");
  for (std::size_t j = 0; j < s.B.size(); ++j) {
    require(bool(s.B[j]), fmt::format("B[{}]", j), "is not set", "a function of t");
    require(std::isfinite(s.tau[j]) && s.tau[j] >= 0, fmt::format("tau[{}]", j),
            fmt::format("latency {} is not usable", s.tau[j]), "a finite latency >= 0");
  }
  require(o.steps_per_period >= 2, "steps_per_period", fmt::format("is {}", o.steps_per_period), "at least 2");
  require(o.max_steps_per_period >= o.steps_per_period, "max_steps_per_period",
          fmt::format("{} is below steps_per_period {}", o.max_steps_per_period, o.steps_per_period), ">= steps_per_period");
  require(std::isfinite(o.tolerance) && o.tolerance > 0, "tolerance", fmt::format("is {}", o.tolerance), "> 0");
  require(o.multipliers >= 1, "multipliers", fmt::format("is {}", o.multipliers), "at least 1");
}

Eigen::MatrixXd sample(const std::function<Eigen::MatrixXd(double)>& f, double t, Eigen::Index n, const std::string& key) {
  Eigen::MatrixXd m = f(t);
  require(m.rows() == n && m.cols() == n, key, fmt::format("is {} x {} at t = {}", m.rows(), m.cols(), t),
          fmt::format("{} x {}", n, n));
  require(m.allFinite(), key, fmt::format("has a non-finite entry at t = {}", t), "finite entries");
  return m;
}

// Two-stage Gauss-Legendre collocation (order 4; Hairer, Norsett & Wanner 1993, Solving ODEs I, II.7).
const double gauss_c[2] = {0.5 - std::sqrt(3.0) / 6, 0.5 + std::sqrt(3.0) / 6};
const double gauss_a[2][2] = {{0.25, 0.25 - std::sqrt(3.0) / 6}, {0.25 + std::sqrt(3.0) / 6, 0.25}};
const double gauss_b[2] = {0.5, 0.5};

// x(t_i + c h - tau) from the grid values x_(i+o): cubic Lagrange on four consecutive offsets o, the newest
// at most +1 (x_(i+1) itself, solved for in the same step when tau < (1 + c) h).
struct Stencil {
  int base = 0;      // offsets base .. base + 3
  double w[4] = {};  // Lagrange weights
};

Stencil stencil(double u) {
  Stencil s;
  s.base = std::min(int(std::floor(u)) - 1, -2);
  for (int m = 0; m < 4; ++m) {
    double w = 1;
    for (int p = 0; p < 4; ++p)
      if (p != m) w *= (u - (s.base + p)) / double(m - p);
    s.w[m] = w;
  }
  return s;
}

// The discretised monodromy matrix for K steps per period: z_i = (x_i, y_(i-1), ..., y_(i-M)), y = C x,
// z_K = Phi z_0. Each step solves the Gauss stages and x_(i+1) (3n unknowns) as a linear map of z_i.
Eigen::MatrixXd discretised_monodromy(const PeriodicDelaySystem& s, int K) {
  const Eigen::Index n = s.n;
  const double h = s.period / K;
  std::vector<std::size_t> delayed;
  for (std::size_t j = 0; j < s.B.size(); ++j)
    if (s.tau[j] > 0) delayed.push_back(j);
  // A (with the zero-delay terms) and the delayed B's at every stage time.
  std::vector<Eigen::MatrixXd> As(2 * std::size_t(K)), Bs(2 * std::size_t(K) * delayed.size());
  std::vector<const Eigen::MatrixXd*> Bptr;
  for (int i = 0; i < K; ++i)
    for (int q = 0; q < 2; ++q) {
      const double t = (i + gauss_c[q]) * h;
      Eigen::MatrixXd A = sample(s.A, t, n, "A");
      for (std::size_t j = 0; j < s.B.size(); ++j)
        if (s.tau[j] == 0) A += sample(s.B[j], t, n, fmt::format("B[{}]", j));
      As[std::size_t(2 * i + q)] = std::move(A);
      for (std::size_t d = 0; d < delayed.size(); ++d) {
        Eigen::MatrixXd& B = Bs[(std::size_t(2 * i + q)) * delayed.size() + d];
        B = sample(s.B[delayed[d]], t, n, fmt::format("B[{}]", delayed[d]));
        Bptr.push_back(&B);
      }
    }
  const Eigen::MatrixXd C = row_space(Bptr, n);
  const Eigen::Index r = C.rows();
  // Stencils per (stage, delay): the same offsets at every step.
  std::vector<Stencil> st(2 * delayed.size());
  int M = 0;
  for (int q = 0; q < 2; ++q)
    for (std::size_t d = 0; d < delayed.size(); ++d) {
      st[std::size_t(q) * delayed.size() + d] = stencil(gauss_c[q] - s.tau[delayed[d]] / h);
      M = std::max(M, -st[std::size_t(q) * delayed.size() + d].base);
    }
  if (r == 0) M = 0;
  std::map<int, Eigen::Index> column;  // offset o < 0 -> its r columns in the right-hand side
  if (r > 0)
    for (const Stencil& sc : st)
      for (int m = 0; m < 4; ++m)
        if (sc.base + m < 0) column.emplace(sc.base + m, 0);
  Eigen::Index cols = n;
  for (auto& [o, c] : column) {
    c = cols;
    cols += r;
  }
  const Eigen::Index N = n + r * M;
  Eigen::MatrixXd X = Eigen::MatrixXd::Identity(n, N);
  std::vector<Eigen::MatrixXd> Y(std::size_t(M + K));  // y_j rows for j = -M .. K - 1 at index j + M
  for (int l = 1; l <= M; ++l) {
    Eigen::MatrixXd y = Eigen::MatrixXd::Zero(r, N);
    y.middleCols(n + (l - 1) * r, r).setIdentity();
    Y[std::size_t(M - l)] = std::move(y);
  }
  const double w[3][2] = {{gauss_a[0][0], gauss_a[0][1]}, {gauss_a[1][0], gauss_a[1][1]}, {gauss_b[0], gauss_b[1]}};
  Eigen::MatrixXd L(3 * n, 3 * n), R(3 * n, cols), Xnew(n, N);
  std::vector<Eigen::MatrixXd> Bts(2 * delayed.size());  // B C^T (n x r) at the two stages of the step
  for (int i = 0; i < K; ++i) {
    L.setIdentity();
    R.setZero();
    for (int q = 0; q < 2; ++q)
      for (std::size_t d = 0; d < delayed.size() && r > 0; ++d)
        Bts[std::size_t(q) * delayed.size() + d] = Bs[std::size_t(2 * i + q) * delayed.size() + d] * C.transpose();
    for (int row = 0; row < 3; ++row) {
      R.block(row * n, 0, n, n).setIdentity();
      for (int q = 0; q < 2; ++q) {
        const double hw = h * w[row][q];
        L.block(row * n, q * n, n, n) -= hw * As[std::size_t(2 * i + q)];
        if (r == 0) continue;
        for (std::size_t d = 0; d < delayed.size(); ++d) {
          const Eigen::MatrixXd& Bt = Bts[std::size_t(q) * delayed.size() + d];
          const Stencil& sc = st[std::size_t(q) * delayed.size() + d];
          for (int m = 0; m < 4; ++m) {
            const int o = sc.base + m;
            if (o == 1) L.block(row * n, 2 * n, n, n) -= (hw * sc.w[m]) * Bt * C;
            else if (o == 0) R.block(row * n, 0, n, n) += (hw * sc.w[m]) * Bt * C;
            else R.block(row * n, column[o], n, r) += (hw * sc.w[m]) * Bt;
          }
        }
      }
    }
    const Eigen::MatrixXd S = L.partialPivLu().solve(R).bottomRows(n);  // x_(i+1) = S (x_i, y_(i+o)...)
    Xnew.noalias() = S.leftCols(n) * X;
    for (const auto& [o, c] : column) Xnew.noalias() += S.middleCols(c, r) * Y[std::size_t(i + o + M)];
    if (r > 0) Y[std::size_t(i + M)] = C * X;
    X.swap(Xnew);
  }
  Eigen::MatrixXd Phi(N, N);
  Phi.topRows(n) = X;
  for (int l = 1; l <= M; ++l) Phi.middleRows(n + (l - 1) * r, r) = Y[std::size_t(K - l + M)];
  return Phi;
}

std::vector<cplx> multipliers_of(const Eigen::MatrixXd& Phi) {
  const Eigen::EigenSolver<Eigen::MatrixXd> es(Phi, false);
  if (es.info() != Eigen::Success)
    throw SolveError(fmt::format("delayed Floquet: eigenvalues of the {0} x {0} monodromy matrix failed", Phi.rows()));
  std::vector<cplx> mu(es.eigenvalues().data(), es.eigenvalues().data() + es.eigenvalues().size());
  std::sort(mu.begin(), mu.end(), [](cplx a, cplx b) {
    return std::abs(a) != std::abs(b) ? std::abs(a) > std::abs(b) : rightmost_first(a, b);
  });
  return mu;
}

// Max over the dominant multipliers (the first `count` with |mu| >= 0.1 rho) of each list of the distance to
// the nearest of the other, over rho. Smaller ones belong to far-left exponents, resolved last and of no
// consequence for stability.
double multiplier_change(const std::vector<cplx>& a, const std::vector<cplx>& b, std::size_t count) {
  const double rho = std::max(std::abs(a.front()), std::abs(b.front()));
  double change = 0;
  for (int pass = 0; pass < 2; ++pass) {
    const auto& p = pass ? b : a;
    const auto& q = pass ? a : b;
    for (std::size_t i = 0; i < std::min(count, p.size()) && std::abs(p[i]) >= 0.1 * rho; ++i) {
      double best = inf;
      for (const cplx& z : q) best = std::min(best, std::abs(p[i] - z));
      change = std::max(change, best);
    }
  }
  return rho > 0 ? change / rho : change;
}

}  // namespace

// Floquet multipliers with delay: fourth-order semi-discretisation of the monodromy, step halving as the check.
DelayFloquet delayed_floquet(const PeriodicDelaySystem& system, const DelayFloquetOptions& options) {
  check_periodic(system, options);
  const std::size_t count = std::size_t(options.multipliers);
  DelayFloquet out;
  auto keep = [&](const std::vector<cplx>& mu, int K, Eigen::Index size) {
    out.multipliers.assign(mu.begin(), mu.begin() + std::ptrdiff_t(std::min(count, mu.size())));
    out.steps_per_period = K;
    out.size = size;
  };
  int K = options.steps_per_period;
  Eigen::MatrixXd Phi = discretised_monodromy(system, K);
  std::vector<cplx> fine = multipliers_of(Phi);
  keep(fine, K, Phi.rows());
  if (!options.check_convergence) return out;
  std::vector<cplx> coarse = multipliers_of(discretised_monodromy(system, std::max(1, K / 2)));
  while (true) {
    out.change = multiplier_change(fine, coarse, count);
    if (out.change / 15 <= options.tolerance) {  // fourth order: the error of mu_K is about |mu_K - mu_(K/2)| / 15
      out.converged = true;
      return out;
    }
    if (2 * K > options.max_steps_per_period) return out;
    K *= 2;
    coarse = std::move(fine);
    Phi = discretised_monodromy(system, K);
    fine = multipliers_of(Phi);
    keep(fine, K, Phi.rows());
  }
}

}  // namespace flapstab
