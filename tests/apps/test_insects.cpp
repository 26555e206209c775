// The shipped insects (data/insects/*.toml) trim to the tolerance and show the published
// derivative pattern and mode structure of hovering insects with the quasi-steady model.
#include <gtest/gtest.h>
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "stability/analysis.hpp"
#include "trim/trim.hpp"

namespace flapstab {
namespace {

struct Result {
  TrimResult trim;
  DerivativeResult der;
  StabilityReport stab;
};

Result analyse(const std::string& insect) {
  const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/" + insect + ".toml");
  const auto model = make_aero_model(c);
  Result r;
  r.trim = trim_hover(c, *model);
  r.der = cycle_averaged_derivatives(*model, c.insect, r.trim.kinematics, c.fluid, c.derivatives.relative_step);
  r.stab = analyse_stability(r.der.table, StabilityRequest{true, {}});
  return r;
}

std::vector<std::string> labels(const StabilityAnalysis& a) {
  std::vector<std::string> l;
  for (const auto& m : a.modes) l.push_back(m.label);
  return l;
}

class Insects : public ::testing::TestWithParam<const char*> {};

// Issue acceptance: residuals below 1e-8 of the weight and of weight x wing length.
TEST_P(Insects, TrimConverges) {
  const Result r = analyse(GetParam());
  ASSERT_TRUE(r.trim.converged) << r.trim.message;
  EXPECT_LT(r.trim.relative_force_residual, 1e-8);
  EXPECT_LT(r.trim.relative_moment_residual, 1e-8);
}

// Sun's group (bumblebee, hoverfly, dronefly, hawkmoth; averaged model; e.g. Sun & Xiong 2005): in hover
// X_u < 0, M_u > 0, Z_w < 0 and M_q < 0 dominate; three longitudinal modes: an unstable oscillatory
// (pitch + surge), a stable fast subsidence and a stable slow subsidence (mainly vertical, w).
TEST_P(Insects, PublishedLongitudinalPattern) {
  const Result r = analyse(GetParam());
  const DerivativeTable& t = r.der.table;
  EXPECT_LT(t.at("Xu"), 0.0);
  EXPECT_GT(t.at("Mu"), 0.0);
  EXPECT_LT(t.at("Zw"), 0.0);
  EXPECT_LT(t.at("Mq"), 0.0);
  ASSERT_TRUE(r.stab.longitudinal);
  const auto l = labels(*r.stab.longitudinal);
  EXPECT_EQ(l, (std::vector<std::string>{"unstable oscillatory", "stable slow subsidence", "stable fast subsidence"}));
  const Mode& slow = r.stab.longitudinal->modes[1];
  EXPECT_EQ(slow.dominant_states.front(), "w");
  const Mode& osc = r.stab.longitudinal->modes[0];
  EXPECT_TRUE(std::count(osc.dominant_states.begin(), osc.dominant_states.end(), "theta") &&
              std::count(osc.dominant_states.begin(), osc.dominant_states.end(), "u"));
}

// Zhang & Sun 2010 (Acta Mech Sin 26:175), dronefly, and the seed thesis: lateral hover has an
// unstable divergence, a stable oscillatory and a stable fast subsidence mode.
TEST_P(Insects, PublishedLateralPattern) {
  const Result r = analyse(GetParam());
  ASSERT_TRUE(r.stab.lateral);
  const auto l = labels(*r.stab.lateral);
  ASSERT_EQ(l.size(), 3u);
  EXPECT_EQ(l[0], "unstable divergence");
  EXPECT_EQ(l[1], "stable oscillatory");
  EXPECT_NE(l[2].find("stable"), std::string::npos);
  EXPECT_NE(l[2].find("subsidence"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(Data, Insects, ::testing::Values("hawkmoth", "fruitfly", "dronefly", "bumblebee"));

// Zhang & Sun 2010 (Acta Mech Sin 26:175): the dronefly's unstable longitudinal mode doubles in ~14 wingbeats
// and its lateral divergence in ~9 (Navier-Stokes derivatives). The quasi-steady model agrees in kind;
// we require the same order (within a factor of 2).
TEST(Insects, DroneflyDoublingTimesHaveThePublishedOrder) {
  const Result r = analyse("dronefly");
  const double lon = *r.stab.longitudinal->modes[0].time_to_double_wingbeats;
  const double lat = *r.stab.lateral->modes[0].time_to_double_wingbeats;
  EXPECT_GT(lon, 14.0 / 2);
  EXPECT_LT(lon, 14.0 * 2);
  EXPECT_GT(lat, 9.0 / 2);
  EXPECT_LT(lat, 9.0 * 2);
}

}  // namespace
}  // namespace flapstab

namespace flapstab {
namespace {

// Sun & Xiong 2005 (J Exp Biol 208:447, summary), hovering bumblebee with Navier-Stokes derivatives:
// unstable oscillatory mode of period 0.32 s doubling in 0.1 s; fast subsidence halving in 0.024 s;
// slow subsidence halving in 0.37 s. The quasi-steady model is a different aerodynamic model, so we
// require agreement within 30 % (it gives 0.35 s, 0.082 s, 0.030 s and 0.33 s).
TEST(Insects, BumblebeeModesMatchSunXiong2005Within30Percent) {
  const Result r = analyse("bumblebee");
  const auto& m = r.stab.longitudinal->modes;
  ASSERT_EQ(m.size(), 3u);
  EXPECT_NEAR(*m[0].period_s, 0.32, 0.3 * 0.32);
  EXPECT_NEAR(*m[0].time_to_double_s, 0.1, 0.3 * 0.1);
  EXPECT_NEAR(*m[1].time_to_half_s, 0.37, 0.3 * 0.37);
  EXPECT_NEAR(*m[2].time_to_half_s, 0.024, 0.3 * 0.024);
}

}  // namespace
}  // namespace flapstab
