// Modes keep their names (hawkmoth, quasi-steady model): the same root has the same name in the longitudinal,
// lateral and 6DoF analyses; Floquet modes and the revolving flyer's modes are paired with the flapping flyer's
// averaged modes by eigenvector similarity; the analyze report's figures (named roots, Floquet multipliers with
// the unit circle, the body's motion on the periodic orbit) and the trimmed mid-stroke incidences.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "apps/floquet_command.hpp"
#include "apps/plots.hpp"
#include "apps/revolving.hpp"
#include "apps/stability_json.hpp"
#include "cfd/aero_factory.hpp"
#include "common/case_text.hpp"

namespace flapstab {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

Case hawkmoth() { return load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml"); }

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string kind(const Mode& m) { return m.conjugate_pair ? "complex" : "real"; }

// Acceptance: every 6DoF mode pairs with a longitudinal or lateral mode of the same shape (similarity ~1) and carries
// its name, each subsystem mode used once.
TEST(HawkmothModeNames, SubsystemAnd6DofTablesAgree) {
  const Case c = hawkmoth();
  const auto model = make_aero_model(c);
  const TrimResult t = trim_hover(c, *model);
  ASSERT_TRUE(t.converged);
  const DerivativeResult d = cycle_averaged_derivatives(*model, c.insect, t.kinematics, c.fluid, c.derivatives.relative_step);
  StabilityRequest req;
  req.six_dof = true;
  const StabilityReport r = analyse_stability(d.table, req);
  ASSERT_TRUE(r.longitudinal && r.lateral && r.coupled);
  std::set<std::pair<std::string, std::size_t>> used;
  for (const SubsystemMatch& m : subsystem_correspondence(r)) {
    const Mode& coupled = r.coupled->modes[m.coupled];
    std::printf("6dof %-36s <- %-12s %-36s similarity %.6f\n", coupled.name.c_str(), m.analysis.c_str(), m.name.c_str(),
                m.similarity);
    ASSERT_FALSE(m.analysis.empty()) << coupled.name;
    EXPECT_GT(m.similarity, 0.99) << coupled.name;
    EXPECT_EQ(coupled.name, m.name);
    const StabilityAnalysis& sub = m.analysis == "longitudinal" ? *r.longitudinal : *r.lateral;
    EXPECT_LT(std::abs(sub.modes[m.index].eigenvalue_nd - coupled.eigenvalue_nd), 1e-6 * std::abs(coupled.eigenvalue_nd));
    EXPECT_TRUE(used.insert({m.analysis, m.index}).second) << "used twice: " << m.name;
  }
  EXPECT_EQ(used.size(), r.longitudinal->modes.size() + r.lateral->modes.size());
  // The names say which motions: Sun's group's hover pattern (tests/apps/test_insects.cpp) in words.
  std::vector<std::string> lon;
  for (const auto& m : r.longitudinal->modes) lon.push_back(m.name);
  EXPECT_EQ(lon, (std::vector<std::string>{"unstable pitch-surge oscillation", "heave subsidence", "pitch-surge subsidence"}));
  std::vector<std::string> lat;
  for (const auto& m : r.lateral->modes) lat.push_back(m.name);
  EXPECT_EQ(lat, (std::vector<std::string>{"roll-sway divergence", "stable roll-yaw-sway oscillation", "roll-yaw subsidence"}));
  // The labels, by contrast, rank among the table's modes: the longitudinal fast subsidence is "intermediate" in 6DoF.
  EXPECT_EQ(r.longitudinal->modes[2].label, "stable fast subsidence");
  // ... and the JSON carries them with the pairing.
  const json j = to_json(r);
  for (std::size_t i = 0; i < r.coupled->modes.size(); ++i) {
    EXPECT_EQ(j["6dof"]["modes"][i]["name"], r.coupled->modes[i].name);
    EXPECT_EQ(j["6dof"]["modes"][i]["subsystem_mode"]["name"], r.coupled->modes[i].name);
  }
}

// Each Floquet mode is beside the averaged mode of the highest eigenvector similarity. For the hawkmoth the
// longitudinal modes are the averaged ones, shifted (similarity > 0.99, the same names); the lateral ones differ
// more, as their exponents do (docs/theory/floquet.md: up to 60 %): the real roots keep similarity > 0.9 and their
// names, the oscillation (measured 0.82) loses most of its yaw in the periodic model and is named without it.
TEST(HawkmothModeNames, FloquetModesPairWithTheMostSimilarAveragedMode) {
  const Case c = hawkmoth();
  const auto model = make_aero_model(c);
  const FloquetStudy s = floquet_study(c, *model);
  for (const FloquetSubsystem* f : {&s.longitudinal, &s.lateral}) {
    ASSERT_TRUE(f->lti);
    const StabilityAnalysis& fl = f->phase_resolved.modes;
    ASSERT_EQ(f->lti_pairing.size(), fl.modes.size());
    ASSERT_EQ(fl.modes.size(), f->lti->modes.size());
    for (const ModePair& p : f->lti_pairing) {
      ASSERT_TRUE(p.b);
      std::size_t best = 0;
      double best_s = -1;
      for (std::size_t j = 0; j < f->lti->modes.size(); ++j) {
        const double sj = mode_similarity(fl.modes[p.a], fl.state_order, f->lti->modes[j], f->lti->state_order,
                                          wing_length_in_chords(fl.reference), wing_length_in_chords(f->lti->reference));
        if (sj > best_s) best_s = sj, best = j;
      }
      const Mode& m = fl.modes[p.a];
      const Mode& a = f->lti->modes[*p.b];
      std::printf("%s Floquet %-36s %+.4f%+.4fi <- averaged %-36s %+.4f%+.4fi similarity %.4f\n", fl.name.c_str(),
                  m.name.c_str(), m.eigenvalue_nd.real(), m.eigenvalue_nd.imag(), a.name.c_str(), a.eigenvalue_nd.real(),
                  a.eigenvalue_nd.imag(), p.similarity);
      EXPECT_EQ(*p.b, best) << m.name;
      EXPECT_NEAR(p.similarity, best_s, 1e-15);
      EXPECT_EQ(m.conjugate_pair, a.conjugate_pair) << m.name;
      if (f == &s.longitudinal) {
        EXPECT_GT(p.similarity, 0.99) << m.name;
        EXPECT_EQ(m.name, a.name);
      } else {
        EXPECT_GT(p.similarity, 0.8) << m.name;
        if (!m.conjugate_pair) {
          EXPECT_GT(p.similarity, 0.9) << m.name;
          EXPECT_EQ(m.name, a.name);
        }
      }
    }
  }
  const json j = floquet_json(c, s);
  ASSERT_EQ(j["longitudinal"]["mode_pairing"].size(), s.longitudinal.phase_resolved.modes.modes.size());
  for (const auto& p : j["longitudinal"]["mode_pairing"]) EXPECT_GT(p["similarity"].get<double>(), 0.99);
}

// The revolving flyer's modes are paired by eigenvector similarity, printed. The pairing is greedy-best: no mode
// of b, same root type or not, is more similar to a mode of a than its partner unless it went to a mode it is at
// least as similar to. So a real root stands beside a complex pair only when no same-type root is more similar and
// free: the motion is the same, its root type changed (for the hawkmoth's lateral modes, measured: the flapping
// roll-yaw-sway oscillation becomes a roll-yaw-sway subsidence, 0.96). Well-matched pairs (> 0.95) move the same
// motions; the rank pairing of the past put the flapping heave subsidence beside a surge subsidence.
TEST(HawkmothModeNames, RevolvingComparisonPairsByEigenvector) {
  const Case c = hawkmoth();
  const auto model = make_aero_model(c);
  const TrimResult t = trim_hover(c, *model);
  ASSERT_TRUE(t.converged);
  const DerivativeResult d = cycle_averaged_derivatives(*model, c.insect, t.kinematics, c.fluid, c.derivatives.relative_step);
  const StabilityReport flapping = analyse_stability(d.table);
  const RevolvingComparison r = compare_with_revolving(c, t.kinematics, *model);
  for (const auto& [fa, ra] : {std::pair{&flapping.longitudinal, &r.stability.longitudinal},
                               std::pair{&flapping.lateral, &r.stability.lateral}}) {
    ASSERT_TRUE(*fa && *ra);
    const StabilityAnalysis &A = **fa, &B = **ra;
    const auto pairs = pair_modes(A, B);
    auto s = [&](std::size_t i, std::size_t k) {
      return mode_similarity(A.modes[i], A.state_order, B.modes[k], B.state_order, wing_length_in_chords(A.reference),
                             wing_length_in_chords(B.reference));
    };
    std::vector<std::optional<std::size_t>> partner_of_b(B.modes.size());
    for (const ModePair& p : pairs)
      if (p.b) partner_of_b[*p.b] = p.a;
    int paired = 0;
    for (const ModePair& p : pairs) {
      const Mode& m = A.modes[p.a];
      if (!p.b) {
        std::printf("%s flapping %-36s unpaired\n", A.name.c_str(), m.name.c_str());
        continue;
      }
      ++paired;
      const Mode& n = B.modes[*p.b];
      std::printf("%s flapping %-36s (%s) <- revolving %-36s (%s) similarity %.4f\n", A.name.c_str(), m.name.c_str(),
                  kind(m).c_str(), n.name.c_str(), kind(n).c_str(), p.similarity);
      EXPECT_NEAR(p.similarity, s(p.a, *p.b), 1e-15);
      for (std::size_t k = 0; k < B.modes.size(); ++k) {
        if (k == *p.b || s(p.a, k) <= p.similarity + 1e-12) continue;
        ASSERT_TRUE(partner_of_b[k]) << m.name << ": a more similar revolving mode was left free: " << B.modes[k].name;
        EXPECT_GE(s(*partner_of_b[k], k), s(p.a, k) - 1e-12) << m.name << " vs " << B.modes[k].name;
      }
      if (p.similarity > 0.95) {
        EXPECT_EQ(m.motions, n.motions) << m.name << " / " << n.name;
      }
    }
    EXPECT_EQ(std::size_t(paired), std::min(A.modes.size(), B.modes.size()));
    if (A.name == "longitudinal") {
      for (const ModePair& p : pairs)
        if (A.modes[p.a].name == "heave subsidence" || A.modes[p.a].name == "pitch-surge subsidence") {
          ASSERT_TRUE(p.b);
          EXPECT_EQ(B.modes[*p.b].name, A.modes[p.a].name);
        }
    }
  }
  const json j = revolving_json(r, &flapping);
  ASSERT_TRUE(j["mode_pairing"].contains("longitudinal"));
  EXPECT_EQ(j["mode_pairing"]["longitudinal"].size(), flapping.longitudinal->modes.size());
}

// Counts the point markers of the gnuplot series titled `title` (the key's sample marker excluded).
int points_of_series(const std::string& svg, const std::string& title) {
  const std::string head = "<title>" + title + "</title>";
  const auto at = svg.find(head);
  if (at == std::string::npos) return -1;
  const auto end = svg.find("<g id=\"gnuplot_plot_", at + head.size());
  const std::string group = svg.substr(at, end == std::string::npos ? std::string::npos : end - at);
  int n = 0;
  for (auto p = group.find("<use"); p != std::string::npos; p = group.find("<use", p + 1)) ++n;
  return n - 1;
}

// The analyze report: its eigenvalue map names every root, the Floquet multiplier map has the unit circle and one
// point per multiplier, the body's motion on the periodic orbit is drawn, and the trimmed mid-stroke incidences are
// in results.json and in the trim table.
TEST(HawkmothModeNames, AnalyzeReportFiguresAndIncidence) {
  const fs::path dir = fs::path(testing::write_temp("x", "")).parent_path() / "mode_names_analyze";
  fs::remove_all(dir);
  const std::string cmd = std::string(FLAPSTAB_BINARY) + " analyze " + FLAPSTAB_SOURCE_DIR +
                          "/data/insects/hawkmoth.toml -q -o " + dir.string();
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const json j = json::parse(read_text(dir / "results.json"));

  // Incidence: for the hawkmoth's pitch series alpha = pitch_mean - 61.875 sin 2 pi tau - 6.875 sin 6 pi tau (no
  // deviation, stroke reversals at tau = 0 and 0.5), the definition gives pitch_mean - 55 deg at mid-downstroke and
  // 180 - (pitch_mean + 55) deg at mid-upstroke.
  const json& inc = j["trim"]["incidence"];
  ASSERT_TRUE(inc.is_object()) << j["trim"].dump();
  double pitch_mean = NAN;
  for (const auto& p : j["trim"]["parameters"])
    if (p["name"] == "pitch_mean_deg") pitch_mean = p["value"];
  ASSERT_TRUE(std::isfinite(pitch_mean));
  const double down = inc["mid_downstroke_deg"], up = inc["mid_upstroke_deg"];
  std::printf("trimmed pitch_mean %.4f deg: incidence %.4f deg (downstroke), %.4f deg (upstroke)\n", pitch_mean, down, up);
  EXPECT_NEAR(inc["mid_downstroke_phase"].get<double>(), 0.25, 1e-6);
  EXPECT_NEAR(inc["mid_upstroke_phase"].get<double>(), 0.75, 1e-6);
  EXPECT_NEAR(down, pitch_mean - 55, 1e-6);
  EXPECT_NEAR(up, 180 - (pitch_mean + 55), 1e-6);
  // Plausible for hovering insects: 20-60 deg (Willmott & Ellington 1997b: 30-40 deg mid-downstroke).
  EXPECT_GT(down, 20);
  EXPECT_LT(down, 60);
  EXPECT_GT(up, 15);
  EXPECT_LT(up, 60);
  const std::string md = read_text(dir / "report.md");
  const auto pm = md.find("| pitch_mean_deg |"), row = md.find("| incidence at mid-downstroke");
  ASSERT_NE(row, std::string::npos);
  EXPECT_LT(pm, row);
  EXPECT_EQ(md.find('\n', pm) + 1, row);  // the next row of the trim table
  EXPECT_NE(md.find("| incidence at mid-upstroke"), std::string::npos);

  if (!gnuplot_available()) GTEST_SKIP() << "gnuplot not installed: no figures";
  // Every root of the eigenvalue map carries its name.
  const std::string eig = read_text(dir / "figures/eigenvalues.svg");
  for (const char* a : {"longitudinal", "lateral"})
    for (const auto& m : j["stability"][a]["modes"]) {
      const std::string name = m["name"];
      EXPECT_NE(eig.find("<text>" + name + "</text>"), std::string::npos) << name;
    }
  // Multipliers: the unit circle (a closed curve through radius 1) and as many points as multipliers.
  const std::string mu = read_text(dir / "figures/floquet_multipliers.svg");
  EXPECT_NE(mu.find("<title>unit circle |μ| = 1</title>"), std::string::npos);
  for (const char* a : {"longitudinal", "lateral"}) {
    const std::size_t n = j["floquet"][a]["multipliers"].size();
    EXPECT_EQ(n, 4u);
    EXPECT_EQ(points_of_series(mu, a), int(n)) << a;
    for (const auto& m : j["floquet"][a]["modes"]) {
      const std::string name = m["name"];
      EXPECT_NE(mu.find("<text>" + name + "</text>"), std::string::npos) << name;
    }
  }
  // The body's motion on the orbit: pitch and both positions.
  const std::string orbit = read_text(dir / "figures/body_oscillation.svg");
  for (const char* s : {"pitch θ (deg, left axis)", "x, forward (mm, right axis)", "z, down (mm, right axis)"})
    EXPECT_NE(orbit.find(std::string("<title>") + s + "</title>"), std::string::npos) << s;
  for (const char* f : {"figures/floquet_multipliers.svg", "figures/body_oscillation.svg"})
    EXPECT_NE(md.find(std::string("](") + f + ")"), std::string::npos) << f;
}

}  // namespace
}  // namespace flapstab
