// Floquet machinery against known answers: constant A, Liouville's formula, Mathieu's first tongue.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <unsupported/Eigen/MatrixFunctions>

#include "stability/floquet.hpp"
#include "stability/lti.hpp"

namespace flapstab {
namespace {

using cplx = std::complex<double>;

// Constant A: Phi(T) = exp(A T) exactly, so the multipliers are exp(lambda T) and the exponents are A's
// eigenvalues. Tolerance 1e-8 relative: CVODE at rtol 1e-10 over a few hundred steps.
TEST(Floquet, ConstantMatrixGivesExponentialMultipliers) {
  Eigen::MatrixXd A(3, 3);
  A << -0.3, 2.0, 0.1, -1.5, -0.2, 0.0, 0.4, 0.3, 0.25;
  const double T = 1.7;
  const MonodromyResult r = monodromy([&](double) { return A; }, 3, T);
  const Eigen::MatrixXd expected = (A * T).exp();
  EXPECT_LT((r.monodromy - expected).norm(), 1e-8 * expected.norm());
  Eigen::EigenSolver<Eigen::MatrixXd> es(A);
  ReferenceQuantities ref{1.0, 1.0, 1.0, 1.0, 1.0 / T, 9.81};  // c / U = 1 s, so nd = per second
  const FloquetAnalysis f =
      floquet_analysis("test", {"u", "w", "theta"}, r.monodromy, T, Eigen::Vector3d::Ones(), ref);
  for (Eigen::Index i = 0; i < 3; ++i) {
    const cplx lam = es.eigenvalues()(i);
    const cplx mu = std::exp(lam * T);
    double best_mu = 1e300, best_lam = 1e300;
    for (std::size_t k = 0; k < 3; ++k) {
      best_mu = std::min(best_mu, std::abs(f.multipliers[k] - mu));
      best_lam = std::min(best_lam, std::abs(f.exponents_per_s[k] - lam));
    }
    EXPECT_LT(best_mu, 1e-8 * std::abs(mu)) << "lambda = " << lam;
    EXPECT_LT(best_lam, 1e-8) << "lambda = " << lam;
  }
  // The exponent matrix is A itself: its modes carry A's eigenvalues and labels.
  ASSERT_EQ(f.modes.modes.size(), 2u);  // one oscillatory pair + one real root
}

// Liouville's formula (e.g. Coddington & Levinson 1955, ch. 1): det Phi(T) = exp(int_0^T tr A dt).
// Here tr A(t) = -0.3 + 0.5 sin t + 0.2 cos 2t, so int_0^T tr A = -0.3 T + 0.5 (1 - cos T) + 0.1 sin 2T.
// Tolerance 1e-8 relative (integration at rtol 1e-10).
TEST(Floquet, LiouvilleFormulaHolds) {
  auto A = [](double t) {
    Eigen::MatrixXd m(3, 3);
    m << -0.3 + 0.5 * std::sin(t), 1.0 + 0.4 * std::cos(t), 0.2, -1.0, 0.2 * std::cos(2 * t), 0.3 * std::sin(3 * t),
        0.1, -0.5 * std::cos(t), 0.0;
    return m;
  };
  const double T = 2 * pi;
  for (double end : {T, 0.7 * T}) {
    const MonodromyResult r = monodromy(A, 3, end);
    const double integral = -0.3 * end + 0.5 * (1 - std::cos(end)) + 0.1 * std::sin(2 * end);
    EXPECT_NEAR(r.monodromy.determinant() / std::exp(integral), 1.0, 1e-8) << "t = " << end;
  }
}

// The spline of a smooth periodic function converges at 4th order; check it is exact at the nodes
// and accurate to 1e-6 between them for N = 64 (error bound ~ (5/384) h^4 max|f''''| ~ 1e-6).
TEST(Floquet, PeriodicSplineInterpolates) {
  const double T = 2.0;
  const int N = 64;
  std::vector<Eigen::MatrixXd> s;
  auto f = [&](double t) {
    Eigen::MatrixXd m(1, 2);
    m << std::sin(2 * pi * t / T), std::cos(4 * pi * t / T) + 0.3;
    return m;
  };
  for (int k = 0; k < N; ++k) s.push_back(f(k * T / N));
  const PeriodicMatrixSpline sp(T, s);
  for (int k = 0; k < N; ++k) EXPECT_LT((sp(k * T / N) - s[std::size_t(k)]).norm(), 1e-14);
  double err = 0;
  for (int i = 0; i < 1000; ++i) err = std::max(err, (sp(i * 0.00317 - 1.0) - f(i * 0.00317 - 1.0)).norm());
  EXPECT_LT(err, 1e-5);
}

// Mathieu equation x'' + (delta + eps cos t) x = 0, T = 2 pi. In the standard form
// y'' + (a - 2 q cos 2z) y = 0 (t = 2z: a = 4 delta, q = -2 eps) the first tongue is bounded by
// a = 1 -/+ q - q^2/8 +/- q^3/64 - q^4/1536 (Abramowitz & Stegun 1964, 20.2.25, the b1 and a1 curves),
// i.e. delta = 1/4 -/+ eps/2 - eps^2/8 +/- eps^3/32 - eps^4/384 + O(eps^5). At eps = 0.1 the edges are
// 0.1987810 and 0.2987185 (truncation ~ 3e-8). Bisection on |tr Phi(T)| = 2 must find them within 1e-4
// (the requirement); we ask for 1e-6.
double mathieu_trace(double delta, double eps) {
  auto A = [&](double t) {
    Eigen::MatrixXd m(2, 2);
    m << 0, 1, -(delta + eps * std::cos(t)), 0;
    return m;
  };
  return monodromy(A, 2, 2 * pi).monodromy.trace();
}

double tongue_edge(double lo, double hi, double eps) {
  // lo stable (|tr| < 2), hi inside the tongue (|tr| > 2), or the reverse.
  const bool lo_stable = std::abs(mathieu_trace(lo, eps)) < 2;
  EXPECT_NE(lo_stable, std::abs(mathieu_trace(hi, eps)) < 2);
  for (int i = 0; i < 40 && hi - lo > 1e-9; ++i) {
    const double mid = 0.5 * (lo + hi);
    ((std::abs(mathieu_trace(mid, eps)) < 2) == lo_stable ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

TEST(Floquet, MathieuFirstTongueEdges) {
  const double eps = 0.1;
  const double lower = 0.25 - eps / 2 - eps * eps / 8 + std::pow(eps, 3) / 32 - std::pow(eps, 4) / 384;
  const double upper = 0.25 + eps / 2 - eps * eps / 8 - std::pow(eps, 3) / 32 - std::pow(eps, 4) / 384;
  EXPECT_NEAR(tongue_edge(0.15, 0.25, eps), lower, 1e-6);
  EXPECT_NEAR(tongue_edge(0.25, 0.35, eps), upper, 1e-6);
  // Inside the tongue the multiplier is real and negative (period-doubling): the analysis says so.
  auto A = [&](double t) {
    Eigen::MatrixXd m(2, 2);
    m << 0, 1, -(0.25 + eps * std::cos(t)), 0;
    return m;
  };
  const MonodromyResult r = monodromy(A, 2, 2 * pi);
  EXPECT_LT(r.monodromy.trace(), -2);
  ReferenceQuantities ref{1.0, 1.0, 1.0, 1.0, 1.0 / (2 * pi), 9.81};
  const FloquetAnalysis f = floquet_analysis("mathieu", {"u", "w"}, r.monodromy, 2 * pi, Eigen::Vector2d::Ones(), ref);
  EXPECT_GT(std::abs(f.multipliers[0]), 1.0);
  EXPECT_FALSE(f.notices.empty());
}

// The LTI longitudinal matrix as a constant periodic system: the Floquet exponents equal the LTI
// eigenvalues and the mode labels agree (to 1e-8).
TEST(Floquet, ConstantHoverSystemReproducesLtiModes) {
  DerivativeTable t;
  t.reference = {4.5, 0.004, 1e-4, 1.225, 155.0, 9.81};
  t.mass = {1.75e-4, 1.5e-9, 4.0e-9, 3.5e-9, 0.0};
  for (const auto& [k, v] : std::vector<std::pair<const char*, double>>{
           {"Xu", -0.8}, {"Xw", 0.05}, {"Xq", -0.1}, {"Zu", -0.03}, {"Zw", -1.0}, {"Zq", -0.03},
           {"Mu", 2.4}, {"Mw", -0.2}, {"Mq", -0.9}})
    t.at(k) = v;
  t.has_longitudinal = true;
  const StateSpace lon = longitudinal_system(t);
  const StabilityAnalysis lti = analyse_modes(lon, t.reference);
  const ReferenceQuantities& ref = t.reference;
  const std::vector<std::string> order{"u", "w", "q", "theta"};
  const Eigen::VectorXd S = nondimensional_state_scale(order, ref);
  // Dimensional A = S^-1 A_nd S / (c / U).
  const Eigen::MatrixXd A_si = S.cwiseInverse().asDiagonal() * lon.A * S.asDiagonal() / ref.time_scale();
  const double T = 1 / ref.frequency;
  const MonodromyResult r = monodromy([&](double) { return A_si; }, 4, T);
  const FloquetAnalysis f = floquet_analysis("longitudinal", order, r.monodromy, T, S, ref);
  ASSERT_EQ(f.modes.modes.size(), lti.modes.size());
  for (std::size_t i = 0; i < lti.modes.size(); ++i) {
    EXPECT_LT(std::abs(f.modes.modes[i].eigenvalue_nd - lti.modes[i].eigenvalue_nd),
              1e-6 * std::abs(lti.modes[i].eigenvalue_nd));
    EXPECT_EQ(f.modes.modes[i].label, lti.modes[i].label);
  }
}

}  // namespace
}  // namespace flapstab
