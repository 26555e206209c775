// Tests of the eigen-analysis and mode classifier (stability/modes.cpp) on textbook spectra.
#include "stability/modes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "stability_fixtures.hpp"

using namespace flapstab;
using cplx = std::complex<double>;

namespace {

// U = 5 m/s, c = 5 mm (c/U = 1 ms), 200 Hz: one wingbeat = 5 units of t+.
ReferenceQuantities reference() { return {5.0, 0.005, 1e-4, 1.2, 200.0, 9.81}; }

// 2x2 block with eigenvalues sigma +- i omega (Etkin & Reid 1996: a damped oscillator's real form).
Eigen::Matrix2d rotation_block(double sigma, double omega) {
  Eigen::Matrix2d b;
  b << sigma, omega, -omega, sigma;
  return b;
}

// Block-diagonal A (known spectrum), disguised by a fixed well-conditioned similarity T A T^-1,
// which keeps the eigenvalues exactly while filling every entry.
StateSpace system_with_blocks(const std::vector<Eigen::MatrixXd>& blocks, bool disguise = true) {
  Eigen::Index n = 0;
  for (const auto& b : blocks) n += b.rows();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  Eigen::Index at = 0;
  for (const auto& b : blocks) A.block(at, at, b.rows(), b.cols()) = b, at += b.rows();
  if (disguise) {
    Eigen::MatrixXd T = Eigen::MatrixXd::Identity(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j)
        if (i != j) T(i, j) = 0.1 * std::sin(1.0 + i + 2.0 * j);
    A = T * A * T.inverse();
  }
  std::vector<std::string> names;
  for (Eigen::Index i = 0; i < n; ++i) {
    std::string name = "x";  // (not "x" + to_string: GCC 12 -Wrestrict false positive)
    name += std::to_string(i);
    names.push_back(name);
  }
  return {"test", names, A, {}, {}};
}

Eigen::MatrixXd scalar(double v) { return Eigen::MatrixXd::Constant(1, 1, v); }

const Mode* find_label(const StabilityAnalysis& a, const std::string& label) {
  for (const auto& m : a.modes)
    if (m.label == label) return &m;
  return nullptr;
}

}  // namespace

TEST(Classifier, StableOscillatoryPair) {
  const auto a = analyse_modes(system_with_blocks({rotation_block(-0.1, 2.0)}), reference());
  ASSERT_EQ(a.modes.size(), 1u);
  const Mode& m = a.modes[0];
  EXPECT_EQ(m.label, "stable oscillatory");
  EXPECT_EQ(m.kind, ModeKind::oscillatory);
  EXPECT_TRUE(m.conjugate_pair);
  EXPECT_NEAR(m.eigenvalue_nd.real(), -0.1, 1e-13);
  EXPECT_NEAR(m.eigenvalue_nd.imag(), 2.0, 1e-13);  // reported by its Im > 0 member
  // zeta = -sigma/|lambda| (python-control damp); period 2 pi/omega; t_half = ln 2/|sigma|.
  EXPECT_NEAR(*m.damping_ratio, 0.1 / std::hypot(0.1, 2.0), 1e-13);
  EXPECT_NEAR(*m.period_nd, std::numbers::pi, 1e-12);
  EXPECT_NEAR(*m.time_to_half_nd, std::numbers::ln2 / 0.1, 1e-10);
  EXPECT_FALSE(m.time_to_double_s.has_value());
}

TEST(Classifier, UnstableOscillatoryPair) {
  const auto a = analyse_modes(system_with_blocks({rotation_block(0.05, 0.5)}), reference());
  ASSERT_EQ(a.modes.size(), 1u);
  EXPECT_EQ(a.modes[0].label, "unstable oscillatory");
  EXPECT_EQ(a.modes[0].stability, ModeStability::unstable);
  EXPECT_LT(*a.modes[0].damping_ratio, 0.0);
  EXPECT_NEAR(*a.modes[0].time_to_double_nd, std::numbers::ln2 / 0.05, 1e-9);
  EXPECT_FALSE(a.modes[0].time_to_half_s.has_value());
}

TEST(Classifier, RealRootsAndZeroRoot) {
  const auto a = analyse_modes(system_with_blocks({scalar(-0.3), scalar(0.2), scalar(0.0)}), reference());
  ASSERT_EQ(a.modes.size(), 3u);
  // Most unstable first.
  EXPECT_EQ(a.modes[0].label, "unstable divergence");
  EXPECT_NEAR(a.modes[0].eigenvalue_nd.real(), 0.2, 1e-13);
  EXPECT_EQ(a.modes[0].eigenvalue_nd.imag(), 0.0);
  EXPECT_FALSE(a.modes[0].period_s.has_value());
  EXPECT_NEAR(*a.modes[0].damping_ratio, -1.0, 1e-13);
  EXPECT_EQ(a.modes[1].label, "neutral");
  EXPECT_EQ(a.modes[1].kind, ModeKind::neutral);
  EXPECT_FALSE(a.modes[1].damping_ratio.has_value());
  EXPECT_FALSE(a.modes[1].time_to_half_s.has_value());
  EXPECT_FALSE(a.modes[1].time_to_double_s.has_value());
  EXPECT_EQ(a.modes[2].label, "stable subsidence");
  EXPECT_NEAR(*a.modes[2].damping_ratio, 1.0, 1e-13);
  EXPECT_NEAR(*a.modes[2].time_to_half_nd, std::numbers::ln2 / 0.3, 1e-10);
}

TEST(Classifier, PureImaginaryPairIsNeutralOscillatory) {
  const auto a = analyse_modes(system_with_blocks({rotation_block(0.0, 1.0), scalar(-1.0)}), reference());
  ASSERT_NE(find_label(a, "neutral oscillatory"), nullptr);
  EXPECT_TRUE(find_label(a, "neutral oscillatory")->period_s.has_value());
}

// A double real root perturbed into +-1e-13 i (what rounding does to a repeated root) is two real
// subsidences, never an oscillatory mode, while a genuine pair beside it stays oscillatory.
TEST(Classifier, ImaginaryNoiseIsReal) {
  const auto a = analyse_modes(system_with_blocks({rotation_block(-0.5, 1e-13), rotation_block(-0.2, 0.3)}, false),
                               reference());
  ASSERT_EQ(a.modes.size(), 3u);
  int subsidences = 0;
  for (const auto& m : a.modes) {
    if (m.kind == ModeKind::subsidence) {
      ++subsidences;
      EXPECT_FALSE(m.conjugate_pair);
      EXPECT_EQ(m.eigenvalue_nd.imag(), 0.0);
      EXPECT_FALSE(m.period_s.has_value());
      EXPECT_NEAR(m.eigenvalue_nd.real(), -0.5, 1e-12);
    }
  }
  EXPECT_EQ(subsidences, 2);
  EXPECT_NE(find_label(a, "stable oscillatory"), nullptr);
}

// Two pairs 1e-6 apart in frequency are paired by tolerance with their own conjugates.
TEST(Classifier, NearbyPairsStayDistinct) {
  const auto a = analyse_modes(system_with_blocks({rotation_block(-0.1, 1.0), rotation_block(-0.1, 1.0 + 1e-6)}, false),
                               reference());
  ASSERT_EQ(a.modes.size(), 2u);
  std::vector<double> w = {a.modes[0].eigenvalue_nd.imag(), a.modes[1].eigenvalue_nd.imag()};
  std::sort(w.begin(), w.end());
  EXPECT_NEAR(w[0], 1.0, 1e-12);
  EXPECT_NEAR(w[1], 1.0 + 1e-6, 1e-12);
  EXPECT_EQ(a.modes[0].label.find("oscillatory") != std::string::npos, true);
}

TEST(Classifier, FastSlowRankingWithinKind) {
  const auto a = analyse_modes(system_with_blocks({scalar(-2.0), scalar(-0.1), rotation_block(-0.05, 0.2),
                                                   rotation_block(-0.3, 3.0), scalar(0.4)}),
                               reference());
  const Mode* fast = find_label(a, "stable fast subsidence");
  const Mode* slow = find_label(a, "stable slow subsidence");
  ASSERT_NE(fast, nullptr);
  ASSERT_NE(slow, nullptr);
  EXPECT_NEAR(fast->eigenvalue_nd.real(), -2.0, 1e-12);
  EXPECT_NEAR(slow->eigenvalue_nd.real(), -0.1, 1e-12);
  ASSERT_NE(find_label(a, "stable fast oscillatory"), nullptr);
  EXPECT_NEAR(find_label(a, "stable fast oscillatory")->eigenvalue_nd.imag(), 3.0, 1e-12);
  ASSERT_NE(find_label(a, "stable slow oscillatory"), nullptr);
  EXPECT_NE(find_label(a, "unstable divergence"), nullptr);  // alone in its kind: no rank

  const auto b = analyse_modes(system_with_blocks({scalar(-2.0), scalar(-0.5), scalar(-0.1)}), reference());
  EXPECT_NE(find_label(b, "stable intermediate subsidence"), nullptr);
}

// lambda per s = lambda+ U/c; wingbeats = seconds x frequency; t_half = ln 2/|sigma|; f_n = |lambda|/2 pi.
// Tolerance 1e-13 relative (a few roundings).
TEST(Classifier, DimensionalTimesAreConsistent) {
  const ReferenceQuantities ref = reference();
  const double U_over_c = ref.U / ref.c;
  const auto a = analyse_modes(system_with_blocks({rotation_block(0.02, 0.15), scalar(-0.4), scalar(0.01)}), ref);
  for (const auto& m : a.modes) {
    const cplx ls = m.eigenvalue_per_s;
    EXPECT_NEAR(std::abs(ls - m.eigenvalue_nd * U_over_c), 0.0, 1e-13 * std::abs(ls));
    EXPECT_NEAR(std::abs(m.eigenvalue_per_wingbeat - ls / ref.frequency), 0.0, 1e-13 * std::abs(ls));
    EXPECT_NEAR(m.natural_frequency_hz, std::abs(ls) / (2 * std::numbers::pi), 1e-13 * m.natural_frequency_hz);
    EXPECT_NEAR(m.natural_frequency_rad_s, std::abs(ls), 1e-13 * std::abs(ls));
    const double sigma = std::abs(ls.real());
    if (m.time_to_half_s) {
      EXPECT_NEAR(*m.time_to_half_s, std::numbers::ln2 / sigma, 1e-13 * *m.time_to_half_s);
      EXPECT_NEAR(*m.time_to_half_wingbeats, *m.time_to_half_s * ref.frequency, 1e-13 * *m.time_to_half_wingbeats);
      EXPECT_NEAR(*m.time_to_half_nd, *m.time_to_half_s * U_over_c, 1e-13 * *m.time_to_half_nd);
    }
    if (m.time_to_double_s) {
      EXPECT_NEAR(*m.time_to_double_s, std::numbers::ln2 / sigma, 1e-13 * *m.time_to_double_s);
      EXPECT_NEAR(*m.time_to_double_wingbeats, *m.time_to_double_s * ref.frequency,
                  1e-13 * *m.time_to_double_wingbeats);
    }
    EXPECT_NEAR(*m.time_constant_s, 1.0 / sigma, 1e-13 / sigma);
    if (m.period_s) {
      EXPECT_NEAR(*m.period_s, 2 * std::numbers::pi / std::abs(ls.imag()), 1e-13 * *m.period_s);
      EXPECT_NEAR(*m.period_wingbeats, *m.period_s * ref.frequency, 1e-13 * *m.period_wingbeats);
    }
  }
  // The unstable pair: sigma+ = 0.02 -> t_double = ln2/0.02 t+ = 34.66 ms = 6.93 wingbeats at 200 Hz.
  const Mode* osc = find_label(a, "unstable oscillatory");
  ASSERT_NE(osc, nullptr);
  EXPECT_NEAR(*osc->time_to_double_s, std::numbers::ln2 / 0.02 * 1e-3, 1e-15);
  EXPECT_NEAR(*osc->time_to_double_wingbeats, std::numbers::ln2 / 0.02 / 5.0, 1e-11);
}

// The normalised eigenvector satisfies A v = lambda v (residual 1e-12 of |A| |v|) and has its
// attitude component (theta or phi, the larger) equal to 1, else its largest component.
TEST(Classifier, EigenvectorNormalisation) {
  const DerivativeTable t = test::hover_like_table();
  for (const auto& sys : {longitudinal_system(t), lateral_system(t), coupled_system(t)}) {
    const auto a = analyse_modes(sys, t.reference);
    for (const auto& m : a.modes) {
      Eigen::VectorXcd v = Eigen::Map<const Eigen::VectorXcd>(m.eigenvector.data(), Eigen::Index(m.eigenvector.size()));
      const double res = (sys.A.cast<cplx>() * v - m.eigenvalue_nd * v).norm();
      EXPECT_LT(res, 1e-12 * sys.A.norm() * v.norm()) << sys.name << " " << m.label;
      const auto k = std::find(sys.state_order.begin(), sys.state_order.end(), m.normalised_by) - sys.state_order.begin();
      ASSERT_LT(std::size_t(k), sys.state_order.size());
      EXPECT_NEAR(std::abs(v(k) - 1.0), 0.0, 1e-14);
      if (m.normalised_by != "theta" && m.normalised_by != "phi") {
        EXPECT_NEAR(v.cwiseAbs().maxCoeff(), 1.0, 1e-14);  // fell back to the largest component
      }
    }
  }
  // A mode with no attitude motion (decoupled heave, theta component exactly 0) is normalised by
  // its largest component, w.
  DerivativeTable d = test::hover_like_table();
  d.at("Xw") = d.at("Xq") = d.at("Mw") = d.at("Zu") = d.at("Zq") = 0;
  const double heave = d.at("Zw") / nondimensional_parameters(d).m;
  int heave_modes = 0;
  for (const auto& m : analyse_modes(longitudinal_system(d), d.reference).modes) {
    if (std::abs(m.eigenvalue_nd - heave) > 1e-12 * std::abs(heave)) {
      EXPECT_EQ(m.normalised_by, "theta");
      continue;
    }
    ++heave_modes;
    EXPECT_EQ(m.normalised_by, "w");
    EXPECT_EQ(m.eigenvector[1], cplx(1.0, 0.0));
  }
  EXPECT_EQ(heave_modes, 1);
}

// Participation factors sum to 1 per mode and do not change when the states are rescaled
// (x -> S x, A -> S A S^-1): the property that makes them a fair measure across u+, q+ and theta.
TEST(Classifier, ParticipationIsScaleInvariant) {
  const DerivativeTable t = test::hover_like_table();
  const StateSpace sys = longitudinal_system(t);
  StateSpace scaled = sys;
  const Eigen::Vector4d s(1000.0, 0.01, 37.0, 1.0);
  scaled.A = s.asDiagonal() * sys.A * s.cwiseInverse().asDiagonal();
  const auto a = analyse_modes(sys, t.reference), b = analyse_modes(scaled, t.reference);
  ASSERT_EQ(a.modes.size(), b.modes.size());
  for (std::size_t k = 0; k < a.modes.size(); ++k) {
    double sum = 0;
    for (std::size_t i = 0; i < 4; ++i) {
      sum += a.modes[k].participation[i];
      EXPECT_NEAR(a.modes[k].participation[i], b.modes[k].participation[i], 1e-9);
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    EXPECT_EQ(a.modes[k].dominant_states, b.modes[k].dominant_states);
  }
}

TEST(Classifier, RejectsBadInput) {
  StateSpace bad = system_with_blocks({scalar(-1.0)});
  bad.A(0, 0) = std::nan("");
  EXPECT_ANY_THROW(analyse_modes(bad, reference()));
  StateSpace wrong = system_with_blocks({scalar(-1.0)});
  wrong.state_order.push_back("extra");
  EXPECT_ANY_THROW(analyse_modes(wrong, reference()));
}
