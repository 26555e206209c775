// Delay systems against closed forms: Hayes' equation, Lambert W roots, Stepan's delayed PD, Floquet with delay.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <limits>

#include "core/errors.hpp"
#include "core/types.hpp"
#include "stability/delayed_feedback.hpp"
#include "stability/floquet.hpp"

namespace flapstab {
namespace {

using cplx = std::complex<double>;

Eigen::MatrixXd scalar(double v) { return Eigen::MatrixXd::Constant(1, 1, v); }

// Hayes' equation x' = a x + b x(t - tau), the gain being b and the latency tau.
DelaySystemBuilder hayes(double a) {
  return [a](double b, double tau) { return DelaySystem{scalar(a), {{scalar(b), tau}}}; };
}

// theta'' - a1 theta' - a0 theta = -P theta(t - tau) - D theta'(t - tau) as x = [theta, theta'].
DelaySystem delayed_pd(double a0, double a1, double P, double D, double tau) {
  Eigen::MatrixXd A(2, 2), B(2, 2);
  A << 0, 1, a0, a1;
  B << 0, 0, -P, -D;
  return DelaySystem{A, {{B, tau}}};
}

// Branch k of Lambert's W at z by Newton on w e^w = z from the asymptotic start L1 - log L1,
// L1 = log z + 2 pi i k (Corless et al. 1996, Adv Comput Math 5:329, asymptotic series).
cplx lambert_w(cplx z, int k) {
  const cplx L1 = std::log(z) + cplx(0, 2 * pi * k);
  cplx w = L1 - std::log(L1);
  for (int it = 0; it < 100; ++it) {
    const cplx ew = std::exp(w);
    const cplx step = (w * ew - z) / (ew * (w + 1.0));
    w -= step;
    if (std::abs(step) < 1e-16 * std::abs(w)) break;
  }
  return w;
}

double nearest(const std::vector<cplx>& roots, cplx z) {
  double best = std::numeric_limits<double>::infinity();
  for (const cplx& r : roots) best = std::min(best, std::abs(r - z));
  return best;
}

// Root rho in (0, pi) of rho cot rho = x (x < 1), by bisection: rho cot rho falls from 1 to -infinity.
double hayes_rho(double x) {
  double lo = 0, hi = pi;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (mid / std::tan(mid) > x ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Hayes (1950, J London Math Soc 25:226): x' = a x + b x(t - tau) is asymptotically stable iff
// a tau < 1, a + b < 0 and -b tau < sqrt((a tau)^2 + rho^2), rho cot rho = a tau. Returns the smallest slack
// of the three conditions, positive when stable (the sign is the verdict, the size a distance from the boundary).
double hayes_margin(double a, double b, double tau) {
  if (tau == 0) return -(a + b);
  const double rho = a * tau < 1 ? hayes_rho(a * tau) : 0;
  return std::min({1 - a * tau, -(a + b), std::sqrt(a * tau * a * tau + rho * rho) + b * tau});
}

// x' = -x(t - 1): lambda e^lambda = -1, so the roots are W_k(-1) (Corless et al. 1996), rightmost
// W_0(-1) = -0.318131505204764 + 1.337235701430689 i, then W_1, W_2 (and conjugates). Tolerance 1e-10 absolute.
TEST(DelayRoots, LambertWRootsOfTheDelayedDecay) {
  const DelayRoots r = rightmost_roots(DelaySystem{scalar(0), {{scalar(-1), 1.0}}});
  ASSERT_EQ(r.roots.size(), 6u);
  EXPECT_TRUE(r.converged);
  EXPECT_NEAR(r.roots[0].real(), -0.318131505204764, 1e-10);
  EXPECT_NEAR(std::abs(r.roots[0].imag()), 1.337235701430689, 1e-10);
  for (int k = 0; k <= 2; ++k) {
    const cplx w = lambert_w(-1.0, k);
    EXPECT_LT(nearest(r.roots, w), 1e-10) << "W_" << k << " = " << w;
    EXPECT_LT(nearest(r.roots, std::conj(w)), 1e-10) << "conj W_" << k;
  }
  for (double res : r.residuals) EXPECT_LT(res, 1e-13);
  EXPECT_LT(std::abs(lambert_w(-1.0, 0) - cplx(-0.318131505204764, 1.337235701430689)), 1e-14);
}

// 24 roots of x' = -x(t - 1) reach W_11(-1) (|lambda| tau about 71), past what N = 20 resolves: the
// check must grow N and still land on W_0..W_11 to 1e-10 (relative to |W_k|).
TEST(DelayRoots, ConvergenceCheckGrowsTheDiscretisation) {
  DelayRootsOptions o;
  o.roots = 24;
  const DelayRoots r = rightmost_roots(DelaySystem{scalar(0), {{scalar(-1), 1.0}}}, o);
  ASSERT_EQ(r.roots.size(), 24u);
  EXPECT_TRUE(r.converged);
  EXPECT_GT(r.nodes, o.nodes);
  EXPECT_LE(r.discretisation_change, o.tolerance);
  for (int k = 0; k <= 11; ++k) {
    const cplx w = lambert_w(-1.0, k);
    EXPECT_LT(nearest(r.roots, w), 1e-10 * std::abs(w)) << "W_" << k;
  }
}

// With every delay zero the roots are the eigenvalues of A + B1 + B2 (to 1e-12); no discretisation.
TEST(DelayRoots, ZeroDelaysGiveTheEigenvaluesOfTheSum) {
  Eigen::MatrixXd A(3, 3), B1(3, 3), B2(3, 3);
  A << -0.3, 2.0, 0.1, -1.5, -0.2, 0.0, 0.4, 0.3, 0.25;
  B1 << 0.1, 0, 0, 0, -0.4, 0.2, 0, 0, -1;
  B2 << 0, 0.3, 0, 0, 0, 0, -0.2, 0, 0;
  const DelayRoots r = rightmost_roots(DelaySystem{A, {{B1, 0.0}, {B2, 0.0}}});
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.nodes, 0);
  ASSERT_EQ(r.roots.size(), 3u);
  const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(A + B1 + B2).eigenvalues();
  for (Eigen::Index i = 0; i < 3; ++i) EXPECT_LT(nearest(r.roots, ev(i)), 1e-12);
  EXPECT_GE(r.roots[0].real(), r.roots[1].real());
  EXPECT_GE(r.roots[1].real(), r.roots[2].real());
}

// The node count and convergence flag: a delayed 2-state system converges at the default N = 20 (the
// comparison with N = 30 passes at 1e-10); with the check off the flag stays false and N is the given one.
TEST(DelayRoots, ReportsNodesAndConvergence) {
  const DelaySystem s = delayed_pd(1.0, 0.0, 1.2, 1.1, 0.5);
  const DelayRoots r = rightmost_roots(s);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.nodes, 20);
  EXPECT_LE(r.discretisation_change, 1e-10);
  DelayRootsOptions o;
  o.check_convergence = false;
  o.nodes = 14;
  const DelayRoots q = rightmost_roots(s, o);
  EXPECT_FALSE(q.converged);
  EXPECT_EQ(q.nodes, 14);
  ASSERT_EQ(q.roots.size(), r.roots.size());
  for (std::size_t k = 0; k < r.roots.size(); ++k) EXPECT_LT(std::abs(q.roots[k] - r.roots[k]), 1e-10);
}

// Hayes' critical delay for b < -|a|: tau* = arccos(-a/b) / sqrt(b^2 - a^2), crossing at omega = sqrt(b^2 - a^2)
// (a = 0, b = -1: pi/2). Tolerance 1e-8 relative on tau* and omega.
TEST(DelayMargin, HayesCriticalDelay) {
  const double cases[][2] = {{0.0, -1.0}, {0.5, -1.0}, {-0.5, -1.0}, {-1.0, -3.0}, {0.2, -4.0}, {0.9, -1.0}};
  for (const auto& [a, b] : cases) {
    const double omega = std::sqrt(b * b - a * a);
    const double tau = std::acos(-a / b) / omega;
    const CriticalLatency c = critical_latency(hayes(a), b, 3 * tau);
    EXPECT_TRUE(c.stable_without_delay);
    EXPECT_NEAR(c.latency / tau, 1.0, 1e-8) << "a = " << a << ", b = " << b;
    EXPECT_NEAR(c.crossing_frequency / omega, 1.0, 1e-8) << "a = " << a << ", b = " << b;
  }
  EXPECT_NEAR(critical_latency(hayes(0.0), -1.0, 4.0).latency, pi / 2, 1e-8);
  // Unstable at latency 0 (a + b > 0), and stable at every latency (b > -|a|, a < 0, a + b < 0): Hayes.
  EXPECT_FALSE(critical_latency(hayes(0.5), -0.2, 2.0).stable_without_delay);
  EXPECT_TRUE(std::isnan(critical_latency(hayes(0.5), -0.2, 2.0).latency));
  const CriticalLatency never = critical_latency(hayes(-1.0), 0.5, 5.0);
  EXPECT_TRUE(never.stable_without_delay);
  EXPECT_EQ(never.latency, std::numeric_limits<double>::infinity());
}

// A builder whose matrix moves with the latency: x' = (tau - 1.5) x + 0.5 x(t - tau). With b = 0.5 > 0 Hayes'
// boundary is the real one a + b = 0 (lambda = 0), crossed at tau = 1 exactly: latency 1 to 1e-10, frequency 0.
TEST(DelayMargin, RealCrossingWhenTheMatrixMovesWithLatency) {
  const DelaySystemBuilder build = [](double b, double tau) {
    return DelaySystem{scalar(tau - 1.5), {{scalar(b), tau}}};
  };
  const CriticalLatency c = critical_latency(build, 0.5, 3.0);
  EXPECT_TRUE(c.stable_without_delay);
  EXPECT_NEAR(c.latency, 1.0, 1e-10);
  EXPECT_EQ(c.crossing_frequency, 0.0);
}

// Sign of the stability map against Hayes' region on a 21 x 26 grid of (b, tau), for a = 0.4 and a = -0.6,
// at points whose closed-form slack exceeds 0.02 (the boundary itself is tested above).
TEST(DelayMargin, StabilityMapMatchesHayesRegion) {
  std::vector<double> gains, latencies;
  for (int i = 0; i <= 20; ++i) gains.push_back(-3.0 + 0.2 * i);
  for (int j = 0; j <= 25; ++j) latencies.push_back(0.1 * j);
  for (double a : {0.4, -0.6}) {
    const StabilityMap map = stability_map(hayes(a), gains, latencies);
    EXPECT_TRUE(map.converged);
    EXPECT_GE(map.nodes, 20);
    int checked = 0, stable = 0;
    for (std::size_t i = 0; i < gains.size(); ++i)
      for (std::size_t j = 0; j < latencies.size(); ++j) {
        const double m = hayes_margin(a, gains[i], latencies[j]);
        if (std::abs(m) < 0.02) continue;
        ++checked;
        stable += m > 0;
        EXPECT_EQ(map.abscissa(Eigen::Index(i), Eigen::Index(j)) < 0, m > 0)
            << "a = " << a << ", b = " << gains[i] << ", tau = " << latencies[j];
      }
    EXPECT_GT(checked, 400);
    EXPECT_GT(stable, 50);
  }
}

// Stepan (1989, Retarded Dynamical Systems) for the delayed PD: besides P = a0, the D-curve
// P(w) = (w^2 + a0) cos(w tau) - a1 w sin(w tau), D(w) = a1 cos(w tau) + (w^2 + a0) sin(w tau) / w bounds the
// stable region; on it lambda = +-i w is a root. a0 = 1, a1 = 0, tau = 1: for w in (0, 1.10) (where the curve
// meets P = a0 again) the root i w is found to 1e-8 and is rightmost (|abscissa| < 1e-8); a step of 2e-3
// along the normal into the region is stable, one out is unstable.
TEST(DelayedPd, BoundaryCurveCarriesImaginaryRoots) {
  const double a0 = 1.0, a1 = 0.0, tau = 1.0;
  auto curve = [&](double w) {
    return Eigen::Vector2d((w * w + a0) * std::cos(w * tau) - a1 * w * std::sin(w * tau),
                           a1 * std::cos(w * tau) + (w * w + a0) * std::sin(w * tau) / w);
  };
  // A point well inside: the region lies between P = a0 and the curve, around its middle.
  const Eigen::Vector2d inside_point(0.5 * (a0 + curve(0.6)(0)), curve(0.6)(1));
  ASSERT_LT(rightmost_roots(delayed_pd(a0, a1, inside_point(0), inside_point(1), tau)).spectral_abscissa(), 0);
  for (double w : {0.3, 0.6, 0.9}) {
    const Eigen::Vector2d pd = curve(w);
    const DelayRoots r = rightmost_roots(delayed_pd(a0, a1, pd(0), pd(1), tau));
    EXPECT_LT(nearest(r.roots, cplx(0, w)), 1e-8) << "w = " << w;
    EXPECT_LT(nearest(r.roots, cplx(0, -w)), 1e-8) << "w = " << w;
    EXPECT_LT(std::abs(r.spectral_abscissa()), 1e-8) << "w = " << w;
    const Eigen::Vector2d tangent = (curve(w + 1e-6) - curve(w - 1e-6)) / 2e-6;
    Eigen::Vector2d normal(-tangent(1), tangent(0));
    normal.normalize();
    if (normal.dot(inside_point - pd) < 0) normal = -normal;
    const Eigen::Vector2d in = pd + 2e-3 * normal, out = pd - 2e-3 * normal;
    EXPECT_LT(rightmost_roots(delayed_pd(a0, a1, in(0), in(1), tau)).spectral_abscissa(), 0) << "w = " << w;
    EXPECT_GT(rightmost_roots(delayed_pd(a0, a1, out(0), out(1), tau)).spectral_abscissa(), 0) << "w = " << w;
  }
  // Left of P = a0 a real root is positive whatever D (Stepan 1989).
  EXPECT_GT(rightmost_roots(delayed_pd(a0, a1, a0 - 2e-3, 1.2, tau)).spectral_abscissa(), 0);
}

// Stepan (1989): the delayed PD stabilises the inverted pendulum (a1 = 0) only while a0 tau^2 < 2. A 41 x 41
// grid of (P, D) over [a0, 1.1 a0 + 0.2] x [0, 3 a0 tau] finds stable points at a0 tau^2 = 1.5 and none at 2.2.
TEST(DelayedPd, InvertedPendulumStabilisableOnlyBelowTwo) {
  const double tau = 1.0;
  for (const double a0 : {1.5, 2.2}) {
    int stable = 0;
    for (int i = 0; i <= 40; ++i)
      for (int j = 0; j <= 40; ++j) {
        const double P = a0 + (0.1 * a0 + 0.2) * i / 40, D = 3 * a0 * tau * j / 40;
        stable += rightmost_roots(delayed_pd(a0, 0.0, P, D, tau)).spectral_abscissa() < 0;
      }
    if (a0 * tau * tau < 2) {
      EXPECT_GT(stable, 0) << "a0 tau^2 = " << a0 * tau * tau;
    } else {
      EXPECT_EQ(stable, 0) << "a0 tau^2 = " << a0 * tau * tau;
    }
  }
}

// Delayed PD with fixed P, gain = D (a1 = 0, P > a0): on lambda = i w, |P + i D w| = w^2 + a0 gives
// s = w^2 > 0 from s^2 + (2 a0 - D^2) s + a0^2 - P^2 = 0 (one positive root), and the phase gives the first
// crossing tau*(D) = atan(D w / P) / w. critical_latency matches it to 1e-8; best_gain's D matches the
// maximiser of the closed form (golden section here) to 1e-4 relative and its latency the maximum to 1e-8.
TEST(DelayMargin, BestDerivativeGainOfTheDelayedPd) {
  const double a0 = 1.0, P = 2.0;
  auto closed = [&](double D) {
    const double p = 2 * a0 - D * D, q = a0 * a0 - P * P;
    const double w = std::sqrt(0.5 * (-p + std::sqrt(p * p - 4 * q)));
    return std::pair(std::atan(D * w / P) / w, w);
  };
  const DelaySystemBuilder build = [&](double D, double tau) { return delayed_pd(a0, 0.0, P, D, tau); };
  for (double D : {0.5, 1.0, 2.0, 3.0}) {
    const CriticalLatency c = critical_latency(build, D, 2.0);
    EXPECT_NEAR(c.latency / closed(D).first, 1.0, 1e-8) << "D = " << D;
    EXPECT_NEAR(c.crossing_frequency / closed(D).second, 1.0, 1e-8) << "D = " << D;
  }
  double lo = 0.2, hi = 4.0;
  const double phi = 0.5 * (std::sqrt(5.0) - 1);
  while (hi - lo > 1e-10) {
    const double x1 = hi - phi * (hi - lo), x2 = lo + phi * (hi - lo);
    if (closed(x1).first > closed(x2).first) {
      hi = x2;
    } else {
      lo = x1;
    }
  }
  const double D_best = 0.5 * (lo + hi);
  const CriticalLatency best = best_gain(build, 0.2, 4.0, 2.0);
  EXPECT_NEAR(best.gain / D_best, 1.0, 1e-4);
  EXPECT_NEAR(best.latency / closed(D_best).first, 1.0, 1e-8);
}

// A constant-coefficient system seen as T-periodic: the monodromy of x' = A x + B x(t - tau) has the
// multipliers exp(lambda T) of its characteristic roots (Hale & Verduyn Lunel 1993, ch. 8), for a period
// longer than the delay and one 2.5 times shorter. Tolerance 1e-6 of the spectral radius at the default 80
// steps for the four rightmost; the step check (80 against 40) must pass at its 1e-6.
TEST(DelayFloquet, ConstantCoefficientsGiveExponentialMultipliers) {
  const DelaySystem s = delayed_pd(1.0, 0.0, 1.2, 1.1, 0.5);
  DelayRootsOptions ro;
  ro.roots = 8;
  const DelayRoots r = rightmost_roots(s, ro);
  for (double T : {0.8, 0.2}) {
    PeriodicDelaySystem p;
    p.period = T;
    p.n = 2;
    p.A = [&](double) { return s.A; };
    p.B = {[&](double) { return s.delayed[0].B; }};
    p.tau = {s.delayed[0].tau};
    const DelayFloquet f = delayed_floquet(p);
    EXPECT_TRUE(f.converged) << "T = " << T << ", change " << f.change;
    EXPECT_EQ(f.steps_per_period, 80);
    const double rho = std::exp(r.spectral_abscissa() * T);
    for (std::size_t k = 0; k < 4; ++k) {
      const cplx mu = std::exp(r.roots[k] * T);
      EXPECT_LT(nearest(f.multipliers, mu), 1e-6 * rho) << "T = " << T << ", lambda = " << r.roots[k];
    }
    EXPECT_NEAR(f.spectral_radius() / rho, 1.0, 1e-6);
  }
}

// The semi-discretisation is fourth order in h (Gauss-Legendre stages, cubic history interpolation): on the
// constant-coefficient system above (T = 0.8) the error of the three dominant multipliers falls by more than
// 12 (16 asymptotically) from K = 20 to K = 40. A tolerance of 1e-9 makes the check double K past 80, and the
// result then matches exp(lambda T) to 1e-8 of rho.
TEST(DelayFloquet, FourthOrderAndStepDoubling) {
  const DelaySystem s = delayed_pd(1.0, 0.0, 1.2, 1.1, 0.5);
  const DelayRoots r = rightmost_roots(s);
  const double T = 0.8, rho = std::exp(r.spectral_abscissa() * T);
  PeriodicDelaySystem p;
  p.period = T;
  p.n = 2;
  p.A = [&](double) { return s.A; };
  p.B = {[&](double) { return s.delayed[0].B; }};
  p.tau = {s.delayed[0].tau};
  auto error = [&](const DelayFloquet& f) {
    double e = 0;
    for (std::size_t k = 0; k < 3; ++k) e = std::max(e, nearest(f.multipliers, std::exp(r.roots[k] * T)) / rho);
    return e;
  };
  DelayFloquetOptions o;
  o.check_convergence = false;
  o.steps_per_period = 20;
  const DelayFloquet f20 = delayed_floquet(p, o);
  o.steps_per_period = 40;
  const DelayFloquet f40 = delayed_floquet(p, o);
  EXPECT_FALSE(f40.converged);
  EXPECT_TRUE(std::isnan(f40.change));
  EXPECT_GT(error(f20) / error(f40), 12.0) << error(f20) << " " << error(f40);
  DelayFloquetOptions tight;
  tight.tolerance = 1e-9;
  const DelayFloquet f = delayed_floquet(p, tight);
  EXPECT_TRUE(f.converged);
  EXPECT_GT(f.steps_per_period, 80);
  EXPECT_LT(error(f), 1e-8);
}

// Without delay the discretised monodromy is the ODE's: damped Mathieu x'' + 0.1 x' + (0.7 + 0.4 cos t) x = 0,
// T = 2 pi, against stability/floquet.hpp's CVODE monodromy (rtol 1e-10). Tolerance 1e-6 relative.
TEST(DelayFloquet, DelayFreeMathieuMatchesIntegratedMonodromy) {
  auto A = [](double t) {
    Eigen::MatrixXd m(2, 2);
    m << 0, 1, -(0.7 + 0.4 * std::cos(t)), -0.1;
    return m;
  };
  const Eigen::MatrixXd M = monodromy(A, 2, 2 * pi).monodromy;
  const Eigen::VectorXcd mu = Eigen::EigenSolver<Eigen::MatrixXd>(M).eigenvalues();
  PeriodicDelaySystem p;
  p.period = 2 * pi;
  p.n = 2;
  p.A = A;
  const DelayFloquet f = delayed_floquet(p);
  EXPECT_TRUE(f.converged);
  EXPECT_EQ(f.size, 2);
  ASSERT_EQ(f.multipliers.size(), 2u);
  for (Eigen::Index k = 0; k < 2; ++k) EXPECT_LT(nearest(f.multipliers, mu(k)), 1e-6 * std::abs(mu(k)));
}

// A genuinely periodic delayed system with a known answer: x = R(alpha(t)) u with R the plane rotation,
// alpha = 0.6 sin(2 pi t / T) and u' = A0 u + B0 u(t - tau) (the delayed PD). Then
//   x' = [alpha' J + R A0 R^T] x + R(t) B0 R(t - tau)^T x(t - tau),  J = [[0, -1], [1, 0]],
// and R is T-periodic, so x and u share the multipliers exp(lambda T) (a periodic Lyapunov transformation;
// Hale & Verduyn Lunel 1993, ch. 8). tau = 0.5, T = 0.2: the delay spans 2.5 periods. Tolerance 1e-6 of rho.
TEST(DelayFloquet, RotatedDelayedPdKeepsItsMultipliers) {
  const DelaySystem s = delayed_pd(1.0, 0.0, 1.2, 1.1, 0.5);
  const double T = 0.2, tau = 0.5, eps = 0.6, w = 2 * pi / T;
  auto R = [&](double t) {
    const double a = eps * std::sin(w * t);
    Eigen::MatrixXd m(2, 2);
    m << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
    return m;
  };
  Eigen::MatrixXd J(2, 2);
  J << 0, -1, 1, 0;
  PeriodicDelaySystem p;
  p.period = T;
  p.n = 2;
  p.A = [&](double t) -> Eigen::MatrixXd { return eps * w * std::cos(w * t) * J + R(t) * s.A * R(t).transpose(); };
  p.B = {[&](double t) -> Eigen::MatrixXd { return R(t) * s.delayed[0].B * R(t - tau).transpose(); }};
  p.tau = {tau};
  const DelayFloquet f = delayed_floquet(p);
  EXPECT_TRUE(f.converged) << "change " << f.change;
  const DelayRoots r = rightmost_roots(s);
  const double rho = std::exp(r.spectral_abscissa() * T);
  for (std::size_t k = 0; k < 4; ++k) {
    const cplx mu = std::exp(r.roots[k] * T);
    EXPECT_LT(nearest(f.multipliers, mu), 1e-6 * rho) << "lambda = " << r.roots[k];
  }
}

// The scalar counterpart: x = e^phi(t) u, phi = 0.5 sin(2 pi t / T), u' = -u(t - 1) gives
// x' = phi' x - e^(phi(t) - phi(t - 1)) x(t - 1) with the multipliers exp(W_k(-1) T); T = 0.4 (the delay spans
// 2.5 periods). Tolerance 1e-6 of rho.
TEST(DelayFloquet, ScalarPeriodicTransformOfTheDelayedDecay) {
  const double T = 0.4, w = 2 * pi / T;
  auto phi = [&](double t) { return 0.5 * std::sin(w * t); };
  PeriodicDelaySystem p;
  p.period = T;
  p.n = 1;
  p.A = [&](double t) { return scalar(0.5 * w * std::cos(w * t)); };
  p.B = {[&](double t) { return scalar(-std::exp(phi(t) - phi(t - 1.0))); }};
  p.tau = {1.0};
  const DelayFloquet f = delayed_floquet(p);
  EXPECT_TRUE(f.converged) << "change " << f.change;
  const double rho = std::abs(std::exp(lambert_w(-1.0, 0) * T));
  for (int k = 0; k <= 1; ++k) {
    const cplx mu = std::exp(lambert_w(-1.0, k) * T);
    EXPECT_LT(nearest(f.multipliers, mu), 1e-6 * rho) << "W_" << k;
    EXPECT_LT(nearest(f.multipliers, std::conj(mu)), 1e-6 * rho) << "W_" << k;
  }
}

TEST(DelayInput, BadDelaysAndSizesAreInputErrors) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(rightmost_roots(DelaySystem{scalar(0), {{scalar(-1), -0.1}}}), InputError);
  EXPECT_THROW(rightmost_roots(DelaySystem{scalar(0), {{scalar(-1), nan}}}), InputError);
  EXPECT_THROW(rightmost_roots(DelaySystem{Eigen::MatrixXd::Zero(2, 2), {{scalar(-1), 1.0}}}), InputError);
  EXPECT_THROW(rightmost_roots(DelaySystem{Eigen::MatrixXd::Zero(2, 3), {}}), InputError);
  EXPECT_THROW(rightmost_roots(DelaySystem{scalar(nan), {}}), InputError);
  DelayRootsOptions o;
  o.nodes = 1;
  EXPECT_THROW(rightmost_roots(DelaySystem{scalar(0), {{scalar(-1), 1.0}}}, o), InputError);
  try {
    rightmost_roots(DelaySystem{scalar(0), {{scalar(-1), 0.5}, {scalar(-1), -2.0}}});
    ADD_FAILURE() << "no throw";
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "delayed[1].tau");
  }
  EXPECT_THROW(critical_latency(hayes(0), -1, -1.0), InputError);
  EXPECT_THROW(critical_latency(hayes(0), -1, nan), InputError);
  EXPECT_THROW(best_gain(hayes(0), -1, -2, 1.0), InputError);
  EXPECT_THROW(stability_map(hayes(0), {-1.0}, {0.5, -0.5}), InputError);

  PeriodicDelaySystem p;
  p.period = 1;
  p.n = 2;
  p.A = [](double) -> Eigen::MatrixXd { return Eigen::MatrixXd::Zero(2, 2); };
  p.B = {[](double) -> Eigen::MatrixXd { return Eigen::MatrixXd::Zero(2, 2); }};
  p.tau = {-0.5};
  EXPECT_THROW(delayed_floquet(p), InputError);
  p.tau = {nan};
  EXPECT_THROW(delayed_floquet(p), InputError);
  p.tau = {0.5, 1.0};
  EXPECT_THROW(delayed_floquet(p), InputError);
  p.tau = {0.5};
  p.B = {[](double) -> Eigen::MatrixXd { return Eigen::MatrixXd::Zero(3, 2); }};
  EXPECT_THROW(delayed_floquet(p), InputError);
  p.B = {[](double) -> Eigen::MatrixXd { return Eigen::MatrixXd::Zero(2, 2); }};
  p.period = 0;
  EXPECT_THROW(delayed_floquet(p), InputError);
}

}  // namespace
}  // namespace flapstab
