// Tests of the stability JSON and Markdown writers (apps/stability_json.cpp): keys, nulls, units.
#include "apps/stability_json.hpp"

#include <gtest/gtest.h>

using namespace flapstab;
using nlohmann::json;

namespace {

// Longitudinal table with a clear spectrum (synthetic numbers, docs/derivative-table.md layout).
DerivativeTable table(bool lateral) {
  DerivativeTable t;
  t.source = "json test";
  t.reference = {4.5, 0.004, 1e-4, 1.225, 155.0, 9.81};
  t.mass = {1.75e-4, 1.5e-9, 4.0e-9, 3.5e-9, 0.0};
  for (auto [k, v] : {std::pair{"Xu", -0.8}, {"Zw", -1.0}, {"Mu", 2.4}, {"Mq", -0.9}, {"Yv", -0.7},
                      {"Lv", 1.5}, {"Lp", -0.9}, {"Nr", -0.6}})
    t.at(k) = v;
  t.has_longitudinal = true;
  t.has_lateral = lateral;
  return t;
}

}  // namespace

TEST(StabilityJson, ModeKeys) {
  const auto r = analyse_stability(table(true));
  const json j = to_json(*r.longitudinal);
  EXPECT_EQ(j["state_order"], json({"u", "w", "q", "theta"}));
  ASSERT_EQ(j["system_matrix_nd"].size(), 4u);
  EXPECT_EQ(j["system_matrix_nd"][3], json({0.0, 0.0, 1.0, 0.0}));
  ASSERT_EQ(j["modes"].size(), 3u);
  for (const auto& m : j["modes"]) {
    for (const char* k : {"eigenvalue_nd", "eigenvalue_per_s", "label", "damping_ratio", "natural_frequency_hz",
                          "period_s", "time_to_double_s", "time_to_half_s", "eigenvector", "dominant_states"})
      EXPECT_TRUE(m.contains(k)) << k;
    EXPECT_EQ(m["eigenvalue_nd"].size(), 2u);
    EXPECT_EQ(m["eigenvector"].size(), 4u);
    EXPECT_EQ(m["eigenvector"][0].size(), 2u);  // [re, im]
    const bool stable = m["stability"] == "stable";
    EXPECT_EQ(m["time_to_half_s"].is_null(), !stable);
    EXPECT_EQ(m["time_to_double_s"].is_null(), stable);
    if (!m["conjugate_pair"].get<bool>()) EXPECT_TRUE(m["period_s"].is_null());
    else EXPECT_GT(m["period_s"].get<double>(), 0.0);
  }
}

TEST(StabilityJson, ReportKeysAndSixDof) {
  StabilityRequest req;
  req.six_dof = true;
  const json j = to_json(analyse_stability(table(true), req));
  for (const char* k : {"conventions", "units", "reference", "nondimensional_parameters", "longitudinal", "lateral",
                        "6dof", "notices"})
    EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["6dof"]["state_order"].size(), 8u);

  const json k = to_json(analyse_stability(table(false)));
  EXPECT_TRUE(k["lateral"].is_null());
  EXPECT_FALSE(k.contains("6dof"));  // not requested
  EXPECT_EQ(k["notices"].size(), 1u);
}

TEST(StabilityJson, MarkdownTableStatesOrderAndUnits) {
  const auto r = analyse_stability(table(true));
  const std::string md = modes_markdown(*r.longitudinal);
  EXPECT_NE(md.find("State order [u, w, q, theta]"), std::string::npos) << md;
  EXPECT_NE(md.find("u (u/U)"), std::string::npos);
  EXPECT_NE(md.find("| mode |"), std::string::npos);
  EXPECT_NE(md.find("wingbeats"), std::string::npos);
  const std::string all = stability_markdown(r);
  EXPECT_NE(all.find("### Longitudinal modes"), std::string::npos);
  EXPECT_NE(all.find("### Lateral modes"), std::string::npos);
}
