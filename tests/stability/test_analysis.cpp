// Tests of analyse_stability (stability/analysis.cpp): which analyses run, skip notices, hover mode structure.
#include "stability/analysis.hpp"

#include <gtest/gtest.h>

#include "stability_fixtures.hpp"

using namespace flapstab;

namespace {

int count_label(const StabilityAnalysis& a, const std::string& label) {
  int n = 0;
  for (const auto& m : a.modes) n += m.label == label;
  return n;
}

bool has_state(const Mode& m, const std::string& s) {
  return std::find(m.dominant_states.begin(), m.dominant_states.end(), s) != m.dominant_states.end();
}

}  // namespace

// The qualitative hover structure Sun's group reports for the bumblebee, dronefly, hoverfly and
// hawkmoth (Sun & Xiong 2005, J Exp Biol 208:447): one unstable oscillatory mode,
// one stable fast subsidence, one stable slow subsidence mainly in w. The table is SYNTHETIC
// (Sun's group's sign pattern, round numbers): no published table with its m+, Iy+ and g+ was
// found to put in data/derivatives/.
TEST(Analysis, HoverLikeLongitudinalStructure) {
  const auto r = analyse_stability(test::hover_like_table());
  ASSERT_TRUE(r.longitudinal.has_value());
  const auto& lon = *r.longitudinal;
  ASSERT_EQ(lon.modes.size(), 3u);
  EXPECT_EQ(count_label(lon, "unstable oscillatory"), 1);
  EXPECT_EQ(count_label(lon, "stable fast subsidence"), 1);
  EXPECT_EQ(count_label(lon, "stable slow subsidence"), 1);
  for (const auto& m : lon.modes) {
    if (m.label == "stable slow subsidence") {
      EXPECT_EQ(m.dominant_states.front(), "w");
    }
    if (m.label == "unstable oscillatory") {
      EXPECT_TRUE(has_state(m, "u") && has_state(m, "theta")) << "pitch and surge";
      EXPECT_FALSE(has_state(m, "w"));
      EXPECT_EQ(m.normalised_by, "theta");
    }
  }
  EXPECT_FALSE(r.coupled.has_value());
  EXPECT_TRUE(r.notices.empty());
}

TEST(Analysis, SixDofOnRequestWithModeCountMatchingStates) {
  StabilityRequest req;
  req.six_dof = true;
  const auto r = analyse_stability(test::hover_like_table(), req);
  ASSERT_TRUE(r.coupled.has_value());
  std::size_t roots = 0;
  for (const auto& m : r.coupled->modes) roots += m.conjugate_pair ? 2 : 1;
  EXPECT_EQ(roots, 8u);
  EXPECT_EQ(r.coupled->modes.size(), r.longitudinal->modes.size() + r.lateral->modes.size());
}

TEST(Analysis, AbsentSectionsAreSkippedWithNotices) {
  DerivativeTable t = test::hover_like_table();
  t.has_lateral = false;
  StabilityRequest req;
  req.six_dof = true;
  const auto r = analyse_stability(t, req);
  EXPECT_TRUE(r.longitudinal.has_value());
  EXPECT_FALSE(r.lateral.has_value());
  EXPECT_FALSE(r.coupled.has_value());
  ASSERT_EQ(r.notices.size(), 2u);
  EXPECT_NE(r.notices[0].find("lateral analysis skipped"), std::string::npos);
  EXPECT_NE(r.notices[1].find("6DoF analysis skipped"), std::string::npos);

  t = test::hover_like_table();
  t.has_longitudinal = false;
  const auto r2 = analyse_stability(t);
  EXPECT_FALSE(r2.longitudinal.has_value());
  EXPECT_TRUE(r2.lateral.has_value());
  ASSERT_EQ(r2.notices.size(), 1u);
  EXPECT_NE(r2.notices[0].find("longitudinal analysis skipped"), std::string::npos);
}

TEST(Analysis, UnusedCouplingIsNoticed) {
  DerivativeTable t = test::hover_like_table();
  t.has_coupling = true;
  t.at("Xv") = 0.1;
  const auto r = analyse_stability(t);
  ASSERT_EQ(r.notices.size(), 1u);
  EXPECT_NE(r.notices[0].find("coupling"), std::string::npos);
}
