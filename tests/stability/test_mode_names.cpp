// Tests of the physical mode names and of the pairing of two mode sets by eigenvector similarity
// (stability/modes.cpp, docs/theory/modes.md).
#include "stability/modes.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "stability/analysis.hpp"
#include "stability_fixtures.hpp"

using namespace flapstab;
using cplx = std::complex<double>;

namespace {

ReferenceQuantities reference() { return {5.0, 0.005, 1e-4, 1.2, 200.0, 9.81}; }

const std::vector<std::string> lon_states{"u", "w", "q", "theta"};

// Longitudinal [u, w, q, theta] with decoupled surge (X_u), heave (Z_w) and pitch (q' = m_q q + m_theta theta).
StateSpace decoupled_longitudinal(double xu, double zw, double mq, double mtheta) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(4, 4);
  A(0, 0) = xu;
  A(1, 1) = zw;
  A(2, 2) = mq;
  A(2, 3) = mtheta;
  A(3, 2) = 1;
  return {"longitudinal", lon_states, A, {}, {}};
}

const Mode* find_name(const StabilityAnalysis& a, const std::string& name) {
  for (const auto& m : a.modes)
    if (m.name == name) return &m;
  return nullptr;
}

std::string names(const StabilityAnalysis& a) {
  std::string s;
  for (const auto& m : a.modes) s += "'" + m.name + "' ";
  return s;
}

}  // namespace

// Pure motions are named by the motion and the root type: a real stable root is a subsidence, a real unstable root a
// divergence, a complex pair an oscillation with its stability.
TEST(ModeNames, PureMotionsAndRootTypes) {
  const auto a = analyse_modes(decoupled_longitudinal(-0.3, 0.2, -0.1, -1.0), reference());
  ASSERT_EQ(a.modes.size(), 3u) << names(a);
  EXPECT_NE(find_name(a, "surge subsidence"), nullptr) << names(a);
  EXPECT_NE(find_name(a, "heave divergence"), nullptr) << names(a);
  const Mode* pitch = find_name(a, "stable pitch oscillation");
  ASSERT_NE(pitch, nullptr) << names(a);
  EXPECT_EQ(pitch->motions, std::vector<std::string>{"pitch"});
  EXPECT_EQ(pitch->label, "stable oscillatory");  // the label is unchanged
  const auto b = analyse_modes(decoupled_longitudinal(-0.3, -0.2, 0.05, 1.0), reference());
  EXPECT_NE(find_name(b, "pitch divergence"), nullptr) << names(b);
  EXPECT_NE(find_name(b, "pitch subsidence"), nullptr) << names(b);
  const auto c = analyse_modes(decoupled_longitudinal(-0.3, -0.2, 0.05, -1.0), reference());
  EXPECT_NE(find_name(c, "unstable pitch oscillation"), nullptr) << names(c);
}

// Rotations count by the velocity they give a point one chord from the CoM (q c/U = lambda+ theta): a slow
// attitude change with a large theta component is still small beside a surge velocity of the same size.
TEST(ModeNames, MotionsInComparableUnits) {
  Mode m;
  m.eigenvalue_nd = -0.01;
  m.eigenvector = {0.5, 0.0, -0.01, 1.0};  // u+ = 0.5, theta = 1, q+ = lambda theta
  const auto motions = mode_motions(m, lon_states);
  ASSERT_EQ(motions.size(), 3u);
  EXPECT_EQ(motions[0].first, "pitch");
  EXPECT_NEAR(std::abs(motions[0].second), 0.01, 1e-15);
  EXPECT_EQ(motions[1].first, "surge");
  EXPECT_EQ(motions[2].first, "heave");
  // Without q the pitch motion is lambda+ theta: the same.
  Mode n = m;
  n.eigenvector = {0.5, 0.0, 1.0};
  const auto without_q = mode_motions(n, {"u", "w", "theta"});
  EXPECT_NEAR(std::abs(without_q[0].second), 0.01, 1e-15);
  // A neutral root (lambda = 0) with only an attitude component is that attitude's motion.
  Mode z;
  z.eigenvalue_nd = 0;
  z.eigenvector = {0.0, 0.0, 0.0, 1.0};
  const auto neutral = mode_motions(z, lon_states);
  EXPECT_EQ(std::abs(neutral[0].second), 1.0);
}

// A surge-pitch coupled mode with both motions above 0.3 of the larger is named by both, pitch first.
TEST(ModeNames, CoupledMotionsInFixedOrder) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(4, 4);
  // u' = -0.05 u - g+ theta (g+ = 0.05), q' = 0.4 u - 0.1 q, theta' = q: the hover pitch-surge pattern; w decoupled.
  A << -0.05, 0, 0, -0.05, 0, -0.2, 0, 0, 0.4, 0, -0.1, 0, 0, 0, 1, 0;
  const auto a = analyse_modes({"longitudinal", lon_states, A, {}, {}}, reference());
  EXPECT_NE(find_name(a, "heave subsidence"), nullptr) << names(a);
  int with_both = 0;
  for (const auto& m : a.modes)
    if (m.motions == std::vector<std::string>{"pitch", "surge"}) {
      ++with_both;
      EXPECT_EQ(m.name.find("pitch-surge"), m.name.find("pitch")) << m.name;
    }
  EXPECT_GE(with_both, 1) << names(a);
}

// Where two modes of one analysis would share a name they are ranked fast/slow by |lambda|; a name met once is
// not ranked, whatever other modes the table holds.
TEST(ModeNames, RankOnlyWhereNamesCoincide) {
  const auto a = analyse_modes(decoupled_longitudinal(-0.3, -0.2, -3.0, -0.5), reference());
  EXPECT_NE(find_name(a, "fast pitch subsidence"), nullptr) << names(a);
  EXPECT_NE(find_name(a, "slow pitch subsidence"), nullptr) << names(a);
  EXPECT_NE(find_name(a, "surge subsidence"), nullptr) << names(a);
  EXPECT_NE(find_name(a, "heave subsidence"), nullptr) << names(a);
}

// The same root has the same name alone (longitudinal, lateral) and in the coupled 6DoF system, although the labels'
// fast/slow ranks change with the company: the "stable fast subsidence in one table, intermediate in the next".
TEST(ModeNames, SameRootSameNameInSubsystemAnd6Dof) {
  const DerivativeTable t = test::hover_like_table();
  StabilityRequest req;
  req.six_dof = true;
  const StabilityReport r = analyse_stability(t, req);
  ASSERT_TRUE(r.longitudinal && r.lateral && r.coupled);
  int matched = 0;
  for (const auto* sub : {&*r.longitudinal, &*r.lateral})
    for (const ModePair& p : pair_modes(*sub, *r.coupled)) {
      ASSERT_TRUE(p.b);
      const Mode& m = sub->modes[p.a];
      const Mode& c = r.coupled->modes[*p.b];
      EXPECT_GT(p.similarity, 0.999) << m.name;
      EXPECT_LT(std::abs(m.eigenvalue_nd - c.eigenvalue_nd), 1e-9 * std::abs(m.eigenvalue_nd)) << m.name;
      EXPECT_EQ(m.name, c.name) << sub->name;
      ++matched;
    }
  EXPECT_EQ(std::size_t(matched), r.coupled->modes.size());
}

// Similarity: 1 for the same shape (whatever complex factor), 0 for motions in different states; symmetric.
TEST(ModePairing, SimilarityOfShapes) {
  Mode a, b, c;
  a.eigenvalue_nd = b.eigenvalue_nd = c.eigenvalue_nd = -0.2;
  a.eigenvector = {1.0, 0.0, 0.3, 0.5};
  b.eigenvector = {cplx(0, 2.0), 0.0, cplx(0, 0.6), cplx(0, 1.0)};  // a times 2i
  c.eigenvector = {0.0, 1.0, 0.0, 0.0};
  EXPECT_NEAR(mode_similarity(a, lon_states, b, lon_states), 1.0, 1e-14);
  EXPECT_NEAR(mode_similarity(a, lon_states, c, lon_states), 0.0, 1e-14);
  // On common states only: a longitudinal mode against a 6DoF vector padded with lateral zeros.
  const std::vector<std::string> six{"u", "v", "w", "p", "q", "r", "phi", "theta"};
  Mode d = a;
  d.eigenvector = {1.0, 0.0, 0.0, 0.0, 0.3, 0.0, 0.0, 0.5};
  EXPECT_NEAR(mode_similarity(a, lon_states, d, six), 1.0, 1e-14);
  EXPECT_NEAR(mode_similarity(d, six, a, lon_states), 1.0, 1e-14);
  // Partly similar shapes lie between.
  Mode e = a;
  e.eigenvector = {1.0, 1.0, 0.3, 0.5};
  const double s = mode_similarity(a, lon_states, e, lon_states);
  EXPECT_GT(s, 0.1);
  EXPECT_LT(s, 0.9);
}

// Pairing follows the eigenvectors, not the ranks: with the surge and heave roots' sizes swapped between two
// analyses, ranking by Re lambda would pair surge with heave; similarity pairs surge with surge.
TEST(ModePairing, PairsByShapeNotByRank) {
  const auto a = analyse_modes(decoupled_longitudinal(-0.3, -0.1, -0.5, -1.0), reference());
  const auto b = analyse_modes(decoupled_longitudinal(-0.1, -0.3, -0.5, -1.0), reference());
  const auto pairs = pair_modes(a, b);
  ASSERT_EQ(pairs.size(), a.modes.size());
  bool rank_would_differ = false;
  for (const ModePair& p : pairs) {
    ASSERT_TRUE(p.b);
    EXPECT_EQ(a.modes[p.a].name, b.modes[*p.b].name);
    EXPECT_NEAR(p.similarity, 1.0, 1e-12);
    rank_would_differ |= a.modes[p.a].name != b.modes[p.a].name;
  }
  EXPECT_TRUE(rank_would_differ) << names(a) << "| " << names(b);
}

// One-to-one: a mode of b is used once; with fewer modes in b the least similar of a stay unpaired.
TEST(ModePairing, OneToOneWithUnequalSets) {
  const auto a = analyse_modes(decoupled_longitudinal(-0.3, -0.1, -0.5, -1.0), reference());
  Eigen::MatrixXd A = Eigen::MatrixXd::Constant(1, 1, -0.2);
  const auto b = analyse_modes({"heave only", {"w"}, A, {}, {}}, reference());
  const auto pairs = pair_modes(a, b);
  int paired = 0;
  for (const ModePair& p : pairs) {
    if (!p.b) continue;
    ++paired;
    EXPECT_EQ(a.modes[p.a].name, "heave subsidence");
    EXPECT_NEAR(p.similarity, 1.0, 1e-12);
  }
  EXPECT_EQ(paired, 1);
}
