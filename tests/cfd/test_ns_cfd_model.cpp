// Tests of the CFD AeroModel (cfd/navier_stokes/cfd_model): the kept periodic hover state, perturbed runs from it
// measured against the continued hover, the settings honoured, and the run cache that makes analyses resumable.
#include <gtest/gtest.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "common/case_text.hpp"
#include "common/model_case.hpp"
#include "common/expect_error.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {
namespace {

namespace fs = std::filesystem;

using testing::model_case;

std::string fresh_dir(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("flapstab_model_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  return d.string();
}

// The hover runs at least [aero.cfd] cycles wingbeats, stops once the cycle-to-cycle change is below
// hover_tolerance (or at max_cycles), and its last wingbeat is the answer for the unperturbed state.
// The window statistics of a perturbed run: a constant sequence has no error and no drift; a straight line
// a + b j over n wingbeats drifts by exactly |b| (n - 1) (scaled), and its standard error is that of the sample;
// scatter without a trend does not drift.
TEST(WindowStatistics, DriftIsTheTrendAcrossTheWindow) {
  const PeriodicSettings s{0.01, 2, 12, 2.0, 0.5};  // tolerance, min, max cycles, force scale, moment scale
  auto w = [](double fx, double my) { return Wrench{Vec3(fx, 0, 0), Vec3(0, my, 0)}; };
  const WindowStatistics flat = window_statistics({w(1, 2), w(1, 2), w(1, 2), w(1, 2)}, s);
  EXPECT_DOUBLE_EQ(flat.mean.force.x(), 1.0);
  EXPECT_DOUBLE_EQ(flat.standard_error, 0.0);
  EXPECT_DOUBLE_EQ(flat.drift, 0.0);
  // Moments rising by 0.01 per wingbeat over 5 wingbeats: 0.04 across the window, / 0.5 = 0.08.
  const WindowStatistics line = window_statistics({w(1, 0.00), w(1, 0.01), w(1, 0.02), w(1, 0.03), w(1, 0.04)}, s);
  EXPECT_NEAR(line.drift, 0.08, 1e-12);
  EXPECT_NEAR(line.mean.moment.y(), 0.02, 1e-15);
  EXPECT_NEAR(line.standard_error, std::sqrt(0.00025 / 5) / 0.5, 1e-12);  // sample variance 2.5e-4
  // Scatter without a trend (symmetric about the window's middle): a standard error, no drift.
  const WindowStatistics bump = window_statistics({w(1, 0.0), w(1, 0.02), w(1, 0.02), w(1, 0.0)}, s);
  EXPECT_NEAR(bump.drift, 0.0, 1e-15);
  EXPECT_NEAR(bump.standard_error, std::sqrt(4e-4 / 3 / 4) / 0.5, 1e-12);
  EXPECT_EQ(window_statistics({w(1, 2)}, s).drift, -1);
}

TEST(CfdModel, HoverHonoursCyclesToleranceAndMaxCycles) {
  for (const auto& [keys, min_cycles, max_cycles] :
       {std::tuple<std::string, int, int>{"cycles = 3\nhover_tolerance = 0.5\nmax_cycles = 6\n", 3, 6},
        {"cycles = 1\nhover_tolerance = 1e-9\nmax_cycles = 4\n", 2, 4}}) {
    SCOPED_TRACE(keys);
    const Case c = model_case("model_hover.toml", keys);
    const CfdModel model(c, nullptr);
    const WrenchHistory h = model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});
    ASSERT_EQ(h.samples.size(), 60u);
    const CfdRunRecord& hover = model.records().at(0);
    EXPECT_GE(int(hover.cycles.size()), min_cycles);
    EXPECT_LE(int(hover.cycles.size()), max_cycles);
    if (hover.converged) {
      EXPECT_LT(hover.final_change(), c.aero.cfd.hover_tolerance);
    } else {
      EXPECT_EQ(int(hover.cycles.size()), max_cycles);
    }
    // The answer is the last wingbeat: its mean is the last cycle mean.
    EXPECT_NEAR(h.mean().force.z(), hover.cycles.back().mean.force.z(), 1e-12);
  }
}

// A perturbed run starts from the kept hover state and is measured against the continued hover: a vanishing
// motion changes nothing (d = 0 to round-off, converged after the minimum three wingbeats), and a forward speed u
// gives a drag X < 0 that flips sign with u, to within the linearity check's asymmetry.
TEST(CfdModel, PerturbedRunsStartFromTheKeptHoverState) {
  const Case c = model_case("model_pert.toml", "cycles = 2\nhover_tolerance = 0.5\nmax_cycles = 5\n"
                                               "perturbation_tolerance = 0.01\n");
  const CfdModel model(c, nullptr);
  const Wrench w0 = model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{}).mean();
  BodyMotion tiny;
  tiny.velocity.x() = 1e-12;
  const Wrench wt = model.run(c.insect, c.kinematics, tiny, AeroRunOptions{}).mean();
  const double W = c.insect.total_mass() * standard_gravity;
  EXPECT_LT((wt.force - w0.force).norm(), 1e-9 * W);
  EXPECT_EQ(model.records().back().cycles.size(), 3u);  // the least: 2 wingbeats in the window
  EXPECT_TRUE(model.records().back().converged);
  const double U = 0.05;  // m/s, about 2 % of the mean wingtip speed
  BodyMotion plus, minus;
  plus.velocity.x() = U;
  minus.velocity.x() = -U;
  const Wrench wp = model.run(c.insect, c.kinematics, plus, AeroRunOptions{}).mean();
  const Wrench wm = model.run(c.insect, c.kinematics, minus, AeroRunOptions{}).mean();
  const double dp = wp.force.x() - w0.force.x(), dm = wm.force.x() - w0.force.x();
  std::printf("  tiny moth: X(+u) - X0 = %.4g N, X(-u) - X0 = %.4g N (weight %.4g N)\n", dp, dm, W);
  EXPECT_LT(dp, 0.0);
  EXPECT_GT(dm, 0.0);
  EXPECT_LT(std::abs(dp + dm), 0.2 * std::abs(dp - dm));  // linear to 20 % over +-2 % of U_ref
  // Every run of the campaign shares the hover's grid and the reference continuation went as far as the runs.
  ASSERT_NE(model.plan(), nullptr);
  std::size_t longest = 0;
  for (const auto& r : model.records()) if (r.label != "hover") longest = std::max(longest, r.cycles.size());
  EXPECT_EQ(model.reference_cycles().size(), longest);
}

// With [aero.cfd.fpm] the continued hover and every run without body rates are force-partitioned, and each run keeps
// its partition's window-mean difference from the continued hover. In a velocity run the parts move in the body's
// frame exactly as in the hover, so the kinematic part (added mass and CAR) of the difference vanishes in theory
// (its potentials and accelerations are those of the hover at the same phases): what remains is the potentials'
// solver tolerance (1e-4 here). A pitch-rate run turns the grid and carries no partition; the cache keeps the
// partition bit for bit.
TEST(CfdModel, VelocityRunsSplitTheirDifferenceByMechanism) {
  const Case c = model_case("model_fpm.toml", "cycles = 2\nhover_tolerance = 0.5\nmax_cycles = 3\n"
                                              "perturbation_tolerance = 0.5\n\n[aero.cfd.fpm]\nsamples_per_cycle = 10\n"
                                              "components = [\"Fx\", \"Fz\", \"My\"]\n");
  ASSERT_TRUE(c.aero.cfd.fpm.enabled);
  const std::string dir = fresh_dir("fpm");
  BodyMotion plus, q;
  plus.velocity.x() = 0.05;  // m/s, about 2 % of the mean wingtip speed
  q.rate.y() = 2.0;
  std::optional<PartitionMeans> kept;
  {
    const CfdModel model(c, nullptr, dir);
    model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});
    model.run(c.insect, c.kinematics, plus, AeroRunOptions{});
    ASSERT_TRUE(model.records().back().partition.has_value());
    const PartitionMeans p = *model.records().back().partition;  // a copy: later runs grow the records
    ASSERT_EQ(p.components, (std::vector<int>{0, 2, 4}));
    for (std::size_t k = 0; k < 3; ++k) {
      const auto& v = p.values[k];
      std::printf("  d%s: pressure %+.4e, kinematic %+.4e (CAR %+.4e), vortex %+.4e, viscous %+.4e, outer %+.4e\n",
                  k == 0 ? "X" : k == 1 ? "Z" : "M", v[PartitionMeans::pressure], v[PartitionMeans::kinematic],
                  v[PartitionMeans::centripetal], v[PartitionMeans::vortex], v[PartitionMeans::viscous],
                  v[PartitionMeans::outer]);
      EXPECT_LT(std::abs(v[PartitionMeans::kinematic]), 1e-3 * std::abs(v[PartitionMeans::pressure])) << k;
    }
    // The forward speed's drag is the largest change: the cut-cell pressure's X difference opposes u.
    EXPECT_LT(p.values[0][PartitionMeans::pressure], 0.0);
    model.run(c.insect, c.kinematics, q, AeroRunOptions{});
    EXPECT_FALSE(model.records().back().partition.has_value());
    kept = p;
  }
  const CfdModel again(c, nullptr, dir);
  again.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});
  again.run(c.insect, c.kinematics, plus, AeroRunOptions{});
  ASSERT_TRUE(again.records().back().reused);
  ASSERT_TRUE(again.records().back().partition.has_value());
  EXPECT_EQ(again.records().back().partition->values, kept->values);
  fs::remove_all(fs::temp_directory_path() / ("flapstab_model_" + std::to_string(::getpid())));
}

// Kinematics asked of the CFD model by an analysis (a trim iterate, a control derivative's run) are checked like
// the case's own: a stroke swept 30 deg back with the wing pitched +-55 deg makes the narrow-based wings cut through
// each other behind the body, and the error names the run and the key.
TEST(CfdModel, OtherKinematicsWhoseWingsMeetAreAnInputErrorNamingTheRun) {
  const Case c = model_case("model_meet.toml", "cycles = 2\nhover_tolerance = 0.5\nmax_cycles = 3\n");
  std::string text = testing::replace(testing::valid_cfd_case_text(), "[kinematics.stroke]\nmean_deg = 0.0",
                                      "[kinematics.stroke]\nmean_deg = -30.0");
  const Case far_back = load_case(testing::write_temp("model_meet_kin.toml", text));
  const CfdModel model(c, nullptr);
  model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});  // the base hover (the case's kinematics)
  const std::string what = testing::expect_input_error(
      [&] { model.run(c.insect, far_back.kinematics, BodyMotion{}, AeroRunOptions{}); }, "wing");
  EXPECT_NE(what.find("the kinematics of CFD run '"), std::string::npos) << what;
  EXPECT_NE(what.find("the left wing meets the right wing"), std::string::npos) << what;
  EXPECT_EQ(what.find("key 'wing'"), what.rfind("key 'wing'")) << "file and key named once: " << what;
}

// With a cache directory, a second model on the same case reuses the hover state and every finished run: the same
// answers bit for bit, nothing recomputed (a killed and restarted analysis loses no finished run).
TEST(CfdModel, CachedRunsAreReusedBitForBit) {
  const Case c = model_case("model_cache.toml", "cycles = 2\nhover_tolerance = 0.5\nmax_cycles = 3\n"
                                                "perturbation_tolerance = 0.5\n");
  const std::string dir = fresh_dir("cache");
  BodyMotion q;
  q.rate.y() = 2.0;  // rad/s: a pitch rate, seen from the turning frame
  WrenchHistory a0, aq;
  {
    const CfdModel first(c, nullptr, dir);
    a0 = first.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});
    aq = first.run(c.insect, c.kinematics, q, AeroRunOptions{});
    EXPECT_FALSE(first.records().back().reused);
  }
  EXPECT_TRUE(fs::exists(dir + "/hover.h5"));
  const CfdModel second(c, nullptr, dir);
  const WrenchHistory b0 = second.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});
  const WrenchHistory bq = second.run(c.insect, c.kinematics, q, AeroRunOptions{});
  EXPECT_TRUE(second.records().at(0).reused);
  EXPECT_TRUE(second.records().back().reused);
  ASSERT_EQ(bq.samples.size(), aq.samples.size());
  for (std::size_t i = 0; i < aq.samples.size(); ++i) {
    EXPECT_EQ(bq.samples[i].total().moment, aq.samples[i].total().moment) << i;
    EXPECT_EQ(b0.samples[i].total().force, a0.samples[i].total().force) << i;
  }
  fs::remove_all(fs::temp_directory_path() / ("flapstab_model_" + std::to_string(::getpid())));
}

// A process killed between writing the continued hover's state and its cycles leaves a state one wingbeat ahead of
// them: the next process sees it by the state's step, makes the continued hover again from the kept hover, and its
// answers are those of a run on a fresh cache, bit for bit.
TEST(CfdModel, AContinuedHoverStateAheadOfItsCyclesIsMadeAgain) {
  const Case c = model_case("model_ref_ahead.toml", "cycles = 2\nhover_tolerance = 0.5\nmax_cycles = 3\n"
                                                    "perturbation_tolerance = 0.5\n");
  const std::string dir = fresh_dir("ref_ahead"), clean = fresh_dir("ref_clean");
  BodyMotion u, w;
  u.velocity.x() = 0.05;
  w.velocity.z() = 0.05;
  {
    const CfdModel first(c, nullptr, dir);
    first.run(c.insect, c.kinematics, u, AeroRunOptions{});
    ASSERT_EQ(first.reference_cycles().size(), 3u);
  }
  // Drop the last wingbeat from reference.json, as if the process had died before writing it.
  nlohmann::json ref = nlohmann::json::parse(std::ifstream(dir + "/reference.json"));
  ref["cycles"].erase(ref["cycles"].size() - 1);
  ref["rows"].erase(ref["rows"].size() - 1);
  std::ofstream(dir + "/reference.json") << ref.dump(1);
  std::ostringstream log;
  const CfdModel second(c, &log, dir);
  const WrenchHistory a = second.run(c.insect, c.kinematics, w, AeroRunOptions{});
  EXPECT_NE(log.str().find("does not end at its 2 wingbeats"), std::string::npos) << log.str();
  const CfdModel fresh(c, nullptr, clean);
  const WrenchHistory b = fresh.run(c.insect, c.kinematics, w, AeroRunOptions{});
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t i = 0; i < a.samples.size(); ++i) {
    EXPECT_EQ(a.samples[i].total().force, b.samples[i].total().force) << i;
    EXPECT_EQ(a.samples[i].total().moment, b.samples[i].total().moment) << i;
  }
  EXPECT_EQ(second.reference_cycles().size(), fresh.reference_cycles().size());
  fs::remove_all(fs::temp_directory_path() / ("flapstab_model_" + std::to_string(::getpid())));
}

// Without a fixed step the periodic runs cannot be phase-locked: an input error naming the key, before any run.
TEST(CfdModel, AdaptiveStepIsAnInputError) {
  Case c = model_case("model_adaptive.toml", "");
  c.aero.cfd.steps_per_cycle = 0;
  const CfdModel model(c, nullptr);
  testing::expect_input_error([&] { model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{}); },
                              "aero.cfd.steps_per_cycle");
}

// Probe (not run by default): how a steady pitch-rate run's moment difference from the continued hover grows with
// the rate, wingbeat by wingbeat, to tell a rate derivative (the difference scales with q at every wingbeat) from a
// response that does not scale (docs/validation.md, "CFD stability chain"). Environment: PROBE_CASE (default the
// shipped fruit fly), PROBE_CPC (cells per chord, default 8), PROBE_RATES (pitch rates in rad/s, comma-separated,
// default 41,20.5,10.25), PROBE_WINGBEATS (default 8), PROBE_BELOW_R and PROBE_SIDE_R (the box, default the case's),
// PROBE_CACHE (the run cache, default none).
TEST(CfdModelStudy, DISABLED_RateResponseProbe) {
  auto env = [](const char* k, const std::string& d) { return std::getenv(k) ? std::string(std::getenv(k)) : d; };
  Case c = load_case(env("PROBE_CASE", std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/fruitfly_cfd.toml"));
  CfdSettings& s = c.aero.cfd;
  s.cells_per_chord = std::stod(env("PROBE_CPC", "8"));
  s.max_cycles = std::stoi(env("PROBE_WINGBEATS", "8"));
  s.perturbation_tolerance = 1e-12;  // every run goes the whole PROBE_WINGBEATS
  if (std::getenv("PROBE_BELOW_R")) s.below_R = std::stod(env("PROBE_BELOW_R", ""));
  if (std::getenv("PROBE_SIDE_R"))
    s.upstream_R = s.downstream_R = s.lateral_R = s.above_R = std::stod(env("PROBE_SIDE_R", ""));
  std::vector<double> rates;
  std::stringstream list(env("PROBE_RATES", "41,20.5,10.25"));
  for (std::string item; std::getline(list, item, ',');) rates.push_back(std::stod(item));
  const CfdModel model(c, &std::cerr, env("PROBE_CACHE", ""));
  model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});
  const double wc = c.insect.weight() * c.insect.wing.mean_chord;
  for (double q : rates) {
    BodyMotion m;
    m.rate.y() = q;
    model.run(c.insect, c.kinematics, m, AeroRunOptions{});
  }
  const auto& ref = model.reference_cycles();
  std::fprintf(stderr, "pitch moment difference from the continued hover, per wingbeat, in units of W c "
                       "(W c = %.4g N m); and divided by q (W c s)\n", wc);
  for (std::size_t r = 0; r < rates.size(); ++r) {
    const CfdRunRecord& rec = model.records().at(r + 1);
    std::fprintf(stderr, "q = %+8.4g rad/s:", rates[r]);
    for (std::size_t k = 0; k < rec.cycles.size() && k < ref.size(); ++k)
      std::fprintf(stderr, " %+.4e", (rec.cycles[k].mean.moment.y() - ref[k].mean.moment.y()) / wc);
    std::fprintf(stderr, "\n   / q   :");
    for (std::size_t k = 0; k < rec.cycles.size() && k < ref.size(); ++k)
      std::fprintf(stderr, " %+.4e", (rec.cycles[k].mean.moment.y() - ref[k].mean.moment.y()) / wc / rates[r]);
    std::fprintf(stderr, "\n");
  }
}

// Not in the suite (half an hour and more): the far field of perturbed runs at Re ~ 1000, with and without the sponge
// layer. Runs the hover from rest, then each body velocity of PROBE_VELOCITIES (comma-separated, "u=0.1" or "w=-0.1",
// fractions of U_ref = 2 Phi f R along x or z of the stability axes) for PROBE_WINGBEATS against the continued hover,
// and prints per wingbeat the hover's cycle-mean lift and each run's force difference from it, or where the run blew
// up (docs/validation.md, "The sponge layer"). Environment: PROBE_CASE (default the shipped hawkmoth),
// PROBE_WINGBEATS (default 10), PROBE_SPONGE_R, PROBE_SPONGE_RATE and PROBE_SPONGE_FACES ([aero.cfd] sponge_R,
// sponge_rate, sponge_faces comma-separated; default the case's), PROBE_SIDE_R (fore, aft, lateral and above
// margins; default the case's), PROBE_HOVER_TOLERANCE (the hover's; a tiny value runs it PROBE_WINGBEATS; with
// PROBE_VELOCITIES empty only the hover runs).
TEST(CfdModelStudy, DISABLED_FarFieldProbe) {
  auto env = [](const char* k, const std::string& d) { return std::getenv(k) ? std::string(std::getenv(k)) : d; };
  Case c = load_case(env("PROBE_CASE", std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/hawkmoth_cfd.toml"));
  CfdSettings& s = c.aero.cfd;
  s.max_cycles = std::stoi(env("PROBE_WINGBEATS", "10"));
  s.perturbation_tolerance = 1e-12;  // every run goes the whole PROBE_WINGBEATS
  if (std::getenv("PROBE_SPONGE_R")) s.sponge_R = std::stod(env("PROBE_SPONGE_R", ""));
  if (std::getenv("PROBE_SPONGE_RATE")) s.sponge_rate = std::stod(env("PROBE_SPONGE_RATE", ""));
  if (std::getenv("PROBE_SPONGE_FACES")) {
    s.sponge_faces.clear();
    std::stringstream faces(env("PROBE_SPONGE_FACES", ""));
    for (std::string f; std::getline(faces, f, ',');) s.sponge_faces.push_back(f);
  }
  if (std::getenv("PROBE_SIDE_R"))
    s.upstream_R = s.downstream_R = s.lateral_R = s.above_R = std::stod(env("PROBE_SIDE_R", ""));
  if (std::getenv("PROBE_HOVER_TOLERANCE")) s.hover_tolerance = std::stod(env("PROBE_HOVER_TOLERANCE", ""));
  const double u_ref = plan_cfd(c, c.kinematics, BodyMotion{}).u_ref, weight = c.insect.weight();
  std::fprintf(stderr, "sponge_R = %g, sponge_rate = %g per wingbeat; U_ref = %.4g m/s, W = %.4g N\n", s.sponge_R,
               s.sponge_rate, u_ref, weight);
  const CfdModel model(c, &std::cerr, "");  // no cache: the key is the case file's, which these changes bypass
  model.run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{});
  std::stringstream list(env("PROBE_VELOCITIES", "u=0.1,w=0.1"));
  std::vector<std::string> labels;
  for (std::string item; std::getline(list, item, ',');) {
    BodyMotion m;
    const double v = std::stod(item.substr(2)) * u_ref;
    (item[0] == 'u' ? m.velocity.x() : m.velocity.z()) = v;
    labels.push_back(item);
    try {
      model.run(c.insect, c.kinematics, m, AeroRunOptions{});
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: stopped: %s\n", item.c_str(), e.what());
      labels.back() += " (stopped)";
    }
  }
  const auto& ref = model.reference_cycles();
  std::fprintf(stderr, "continued hover, -F_z / W per wingbeat:");
  for (const auto& r : ref) std::fprintf(stderr, " %.4f", -r.mean.force.z() / weight);
  std::fprintf(stderr, "\n");
  for (std::size_t r = 0; r + 1 < model.records().size(); ++r) {
    const CfdRunRecord& rec = model.records().at(r + 1);
    std::fprintf(stderr, "%s, (dX, dZ) / W per wingbeat:", rec.label.c_str());
    for (std::size_t k = 0; k < rec.cycles.size() && k < ref.size(); ++k)
      std::fprintf(stderr, " (%+.4f, %+.4f)", (rec.cycles[k].mean.force.x() - ref[k].mean.force.x()) / weight,
                   (rec.cycles[k].mean.force.z() - ref[k].mean.force.z()) / weight);
    std::fprintf(stderr, "\n");
  }
}

}  // namespace
}  // namespace flapstab::ns
