// The example cases in data/examples/ (one per feature, listed in docs/user-guide.md "Examples"): each runs as its
// header says, and the guide lists every one of them.
#include <gtest/gtest.h>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include "common/case_text.hpp"
#include "common/expect_error.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "core/case_file.hpp"
#include "core/rotation.hpp"

namespace flapstab {
namespace {

namespace fs = std::filesystem;

const std::string source = FLAPSTAB_SOURCE_DIR;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct CliResult {
  int status;
  std::string err;
};

CliResult flapstab(const std::string& args) {
  const std::string err = testing::write_temp("examples_stderr.txt", "");
  const int rc = std::system((std::string(FLAPSTAB_BINARY) + " " + args + " > /dev/null 2> " + err).c_str());
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(err)};
}

fs::path out_dir(const std::string& name) {
  const fs::path d = fs::path(testing::write_temp("x", "")).parent_path() / ("example_" + name);
  fs::remove_all(d);
  return d;
}

nlohmann::json json_of(const fs::path& p) { return nlohmann::json::parse(slurp(p)); }

// analyze: a report and results.json, with a converged trim and a verdict.
nlohmann::json analyze(const std::string& example) {
  const fs::path dir = out_dir(example);
  const CliResult r = flapstab("analyze " + source + "/data/examples/" + example + " -q -o " + dir.string());
  EXPECT_EQ(r.status, 0) << example << ": " << r.err;
  EXPECT_TRUE(fs::exists(dir / "report.md")) << example;
  if (!fs::exists(dir / "results.json")) return {};
  const nlohmann::json j = json_of(dir / "results.json");
  EXPECT_TRUE(j.contains("verdict")) << example;
  return j;
}

nlohmann::json trim(const std::string& path) {
  const fs::path dir = out_dir(fs::path(path).stem().string() + "_trim");
  const CliResult r = flapstab("trim-hover " + path + " -q -o " + dir.string());
  EXPECT_EQ(r.status, 0) << path << ": " << r.err;
  return fs::exists(dir / "trim.json") ? json_of(dir / "trim.json") : nlohmann::json{};
}

// The text of a file of the source tree (path relative to it) with each (from, to) edit made once; the test fails
// when a `from` is missing.
std::string edited(const std::string& path, const std::vector<std::pair<std::string, std::string>>& edits) {
  std::string text = slurp(source + "/" + path);
  for (const auto& [from, to] : edits) text = testing::replace(text, from, to);
  return text;
}

TEST(Examples, RevolvingFlyer) {
  const nlohmann::json j = analyze("revolving_hawkmoth.toml");
  ASSERT_FALSE(j.is_null());
  EXPECT_TRUE(j["trim"]["converged"].get<bool>());
}

TEST(Examples, HermiteKinematicsTrimLikeTheirFourierSeries) {
  // The nodes sample the hawkmoth's pitch series: the trim moves only by the interpolation error.
  const nlohmann::json h = analyze("hermite_hawkmoth.toml");
  const nlohmann::json f = trim(source + "/data/insects/hawkmoth.toml");
  ASSERT_FALSE(h.is_null() || f.is_null());
  for (std::size_t i = 0; i < 3; ++i)
    EXPECT_NEAR(double(h["trim"]["parameters"][i]["value"]), double(f["trim"]["parameters"][i]["value"]), 0.5)
        << f["trim"]["parameters"][i]["name"];
}

TEST(Examples, BermanWangAnglesTrimThroughTheirShape) {
  // The stroke's K balances the weight (with the stroke and pitch means); the trimmed kinematics keep their form.
  const nlohmann::json j = analyze("berman_wang_hawkmoth.toml");
  ASSERT_FALSE(j.is_null());
  EXPECT_TRUE(j["trim"]["converged"].get<bool>());
  EXPECT_EQ(j["trim"]["parameters"][0]["name"], "stroke_shape_k");
  const nlohmann::json& stroke = j["trim"]["kinematics"]["right"]["stroke"];
  EXPECT_EQ(stroke["type"], "berman-wang");
  EXPECT_NEAR(double(stroke["shape_k"]), double(j["trim"]["parameters"][0]["value"]), 1e-12);
}

TEST(Examples, MarsGravityTrimsAtTheScaledFrequency) {
  // Quasi-steady loads scale as n^2 at fixed angles, so the trimmed frequency scales as sqrt(g): the same case
  // without [environment] (standard gravity) must trim at sqrt(9.80665 / 3.71) times the frequency, with the same
  // means (analytic similarity; 1e-8 relative, the trim tolerance).
  const nlohmann::json mars = analyze("mars_gravity_hawkmoth.toml");
  const std::string text = edited("data/examples/mars_gravity_hawkmoth.toml", {{"[environment]\ngravity_m_s2 = 3.71", ""}});
  const nlohmann::json earth = trim(testing::write_temp("earth_gravity_hawkmoth.toml", text));
  ASSERT_FALSE(mars.is_null() || earth.is_null());
  const auto& pm = mars["trim"]["parameters"];
  const auto& pe = earth["trim"]["parameters"];
  EXPECT_EQ(pm[0]["name"], "frequency_hz");
  EXPECT_NEAR(double(pe[0]["value"]) / double(pm[0]["value"]), std::sqrt(9.80665 / 3.71), 1e-8);
  EXPECT_NEAR(double(pe[1]["value"]), double(pm[1]["value"]), 1e-6);
  EXPECT_NEAR(double(pe[2]["value"]), double(pm[2]["value"]), 1e-6);
}

TEST(Examples, PolynomialPlanformSetsTheReferenceSpeed) {
  // c ~ 1 + x - 1.8 x^2 (x = r/R): r2^2 / R^2 = (1/3 + 1/4 - 1.8/5) / (1 + 1/2 - 1.8/3) exactly, and the reference
  // speed is U = 2 Phi n r2 (Phi the trimmed amplitude in rad) - to round-off (1e-12).
  const nlohmann::json j = analyze("polynomial_planform_hawkmoth.toml");
  ASSERT_FALSE(j.is_null());
  EXPECT_TRUE(j["trim"]["converged"].get<bool>());
  const double r2 = std::sqrt((1.0 / 3 + 1.0 / 4 - 1.8 / 5) / (1 + 1.0 / 2 - 1.8 / 3)) * 0.0519;
  const double phi = double(j["trim"]["parameters"][0]["value"]) * 3.14159265358979323846 / 180;
  EXPECT_EQ(j["trim"]["parameters"][0]["name"], "stroke_amplitude_deg");
  EXPECT_NEAR(double(j["derivatives"]["reference"]["U_m_s"]), 2 * phi * 26.1 * r2, 1e-12 * 2 * phi * 26.1 * r2);
}

TEST(Examples, CoefficientTableTrimsLikeTheSetItSamples) {
  // The table samples the Berman-Wang forms every 10 deg: the clamped spline's error is at most h^4 max|f^(4)| / 27 =
  // (10 deg)^4 x 16 x 1.678 / 27 = 9e-4, a relative lift error of 5e-4 at most, which moves the trimmed amplitude
  // (Phi ~ C_L^(-1/2)) by at most 120 deg x 2.7e-4 = 0.03 deg: 0.05 deg stated for every parameter.
  const nlohmann::json t = analyze("coefficient_table_hawkmoth.toml");
  const std::string text =
      edited("data/insects/hawkmoth.toml", {{"coefficients = \"robofly\"", "coefficients = \"berman-wang\""}});
  const nlohmann::json b = trim(testing::write_temp("hawkmoth_berman_wang_set.toml", text));
  ASSERT_FALSE(t.is_null() || b.is_null());
  for (std::size_t i = 0; i < 3; ++i)
    EXPECT_NEAR(double(t["trim"]["parameters"][i]["value"]), double(b["trim"]["parameters"][i]["value"]), 0.05)
        << b["trim"]["parameters"][i]["name"];
}

TEST(Examples, PublishedRoboflyConstantsGiveTheDefaultTrimBitForBit) {
  const nlohmann::json c = trim(source + "/data/examples/robofly_constants_hawkmoth.toml");
  const nlohmann::json h = trim(source + "/data/insects/hawkmoth.toml");
  ASSERT_FALSE(c.is_null() || h.is_null());
  EXPECT_EQ(c["trim"]["parameters"], h["trim"]["parameters"]);
  EXPECT_EQ(c["trim"]["residuals"], h["trim"]["residuals"]);
}

TEST(Examples, FourWingsOfTwoIdenticalPairsTrimAtOneOverSqrtTwo) {
  // Two identical pairs in phase with half the wing mass each: the hawkmoth's mass properties and twice one pair's
  // loads, which scale as n^2 at fixed angles - the trimmed frequency is the two-winged hawkmoth's / sqrt(2), with
  // the same means (analytic similarity; 1e-8 relative, the trim tolerance).
  const nlohmann::json four = analyze("four_wing_hawkmoth.toml");
  const std::string text = edited("data/insects/hawkmoth.toml", {{"name = \"stroke_amplitude_deg\"", "name = \"frequency_hz\""},
                                                               {"lower = 90.0", "lower = 5.0"},
                                                               {"upper = 150.0", "upper = 40.0"}});
  const nlohmann::json two = trim(testing::write_temp("two_wing_frequency_hawkmoth.toml", text));
  ASSERT_FALSE(four.is_null() || two.is_null());
  const auto& p4 = four["trim"]["parameters"];
  const auto& p2 = two["trim"]["parameters"];
  EXPECT_EQ(p4[0]["name"], "frequency_hz");
  EXPECT_NEAR(double(p2[0]["value"]) / double(p4[0]["value"]), std::sqrt(2.0), 1e-8);
  EXPECT_NEAR(double(p2[1]["value"]), double(p4[1]["value"]), 1e-6);
  EXPECT_NEAR(double(p2[2]["value"]), double(p4[2]["value"]), 1e-6);
  EXPECT_TRUE(four["trim"]["kinematics"].contains("hind"));
}

TEST(Examples, BodyFixedStrokePlaneGivesTheSameWingbeat) {
  // -49.3 deg from the body axis at a 34.3 deg body angle is the hawkmoth's -15 deg from the horizontal: the same
  // trim (1e-8, the trim tolerance; the two stroke-plane rotations differ in the last bits only).
  const nlohmann::json b = analyze("body_stroke_plane_hawkmoth.toml");
  const nlohmann::json h = trim(source + "/data/insects/hawkmoth.toml");
  ASSERT_FALSE(b.is_null() || h.is_null());
  EXPECT_EQ(b["trim"]["kinematics"]["stroke_plane_reference"], "body");
  for (std::size_t i = 0; i < 3; ++i)
    EXPECT_NEAR(double(b["trim"]["parameters"][i]["value"]), double(h["trim"]["parameters"][i]["value"]), 1e-8)
        << h["trim"]["parameters"][i]["name"];
}

// Largest |a - b| over two JSON arrays or objects of numbers (nested), relative to max(1, |b|).
double largest_difference(const nlohmann::json& a, const nlohmann::json& b) {
  if (a.is_number()) return std::abs(double(a) - double(b)) / std::max(1.0, std::abs(double(b)));
  double d = 0;
  if (a.is_array())
    for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, largest_difference(a[i], b[i]));
  else if (a.is_object())
    for (auto it = a.begin(); it != a.end(); ++it)
      if (it.value().is_number() || it.value().is_structured()) d = std::max(d, largest_difference(it.value(), b[it.key()]));
  return d;
}

TEST(Examples, RigidAbdomenEqualsTheCombinedBody) {
  // The example's abdomen oscillates; held rigid at a bent 8 deg it is one body with the combined mass properties
  // (mass, CoM d = m_a p / m, inertia by the parallel-axis theorem, the hinge moved by -d, written at 17 digits):
  // the same trim, derivatives, LTI eigenvalues and Floquet exponents to round-off (measured: trim 2e-14,
  // derivatives 1e-13 - round-off over the 1 % difference step -, eigenvalues 8e-15) and, for the exponents, to the
  // cyclic trim's integration (measured 1.5e-11: two adaptive CVODES runs at rtol 1e-12 from 1e-16-close inputs).
  const nlohmann::json osc = analyze("abdomen_hawkmoth.toml");
  ASSERT_FALSE(osc.is_null());
  EXPECT_TRUE(osc["trim"]["converged"].get<bool>());
  EXPECT_TRUE(osc["floquet"]["cyclic_trim"]["converged"].get<bool>());
  const std::string rigid = edited("data/examples/abdomen_hawkmoth.toml", {{"mean_deg = 0.0\ncos_deg = [5.0]", "mean_deg = 8.0"}});
  const std::string rigid_path = testing::write_temp("rigid_abdomen_hawkmoth.toml", rigid);
  const Case c = load_case(rigid_path);
  const Abdomen& a = *c.insect.abdomen;
  const Mat3 R = rot_y(8 * deg);
  const Vec3 p = a.joint + R * a.centre;
  const double m = c.insect.body.mass + a.mass;
  const Vec3 d = a.mass * p / m;
  auto shift = [](double mass, const Vec3& r) { return mass * (r.squaredNorm() * Mat3::Identity() - r * r.transpose()); };
  const Mat3 I = c.insect.body.inertia + shift(c.insect.body.mass, d) + R * a.inertia_cg * R.transpose() + shift(a.mass, p - d);
  const Vec3 h = c.insect.wing.hinge - d;
  std::string one = rigid;
  one = testing::replace(one, one.substr(one.find("[abdomen]\n"), one.find("[wing]") - one.find("[abdomen]\n")), "");
  one = testing::replace(one, "mass_kg = 0.654e-3", fmt::format("mass_kg = {:.17g}", m));
  one = testing::replace(one, "height_m = 0.010\n",
                         fmt::format("height_m = 0.010\ninertia_kg_m2 = {{ xx = {:.17g}, yy = {:.17g}, zz = {:.17g}, xz = {:.17g} }}\n",
                                     I(0, 0), I(1, 1), I(2, 2), -I(0, 2)));
  one = testing::replace(one, "hinge_m = [-0.008286, 0.0050, -0.004833]",
                         fmt::format("hinge_m = [{:.17g}, {:.17g}, {:.17g}]", h.x(), h.y(), h.z()));
  const fs::path dr = out_dir("rigid_abdomen"), d1 = out_dir("combined_body");
  ASSERT_EQ(flapstab("analyze " + rigid_path + " -q -o " + dr.string()).status, 0);
  ASSERT_EQ(flapstab("analyze " + testing::write_temp("combined_body_hawkmoth.toml", one) + " -q -o " + d1.string()).status, 0);
  const nlohmann::json jr = json_of(dr / "results.json"), j1 = json_of(d1 / "results.json");
  const double trim = largest_difference(jr["trim"]["parameters"], j1["trim"]["parameters"]);
  const double der = largest_difference(jr["derivatives"]["nondimensional"], j1["derivatives"]["nondimensional"]);
  double eig = 0;
  for (std::size_t i = 0; i < j1["stability"]["6dof"]["modes"].size(); ++i)
    eig = std::max(eig, largest_difference(jr["stability"]["6dof"]["modes"][i]["eigenvalue_nd"],
                                           j1["stability"]["6dof"]["modes"][i]["eigenvalue_nd"]));
  const double floq = largest_difference(jr["floquet"]["exponents_nd"], j1["floquet"]["exponents_nd"]);
  std::printf("    rigid abdomen vs combined body: trim %.3g, derivatives %.3g, eigenvalues %.3g, Floquet exponents %.3g\n",
              trim, der, eig, floq);
  EXPECT_LT(trim, 1e-11);
  EXPECT_LT(der, 1e-11);
  EXPECT_LT(eig, 1e-11);
  EXPECT_LT(floq, 1e-9);
  // And the oscillation does change the result (the comparison is not vacuous).
  EXPECT_GT(largest_difference(osc["floquet"]["exponents_nd"], jr["floquet"]["exponents_nd"]), 1e-6);
}

// `flapstab COMMAND CASE -q -o DIR` refuses the case: exit 2, a message naming `key`, no DIR.
void expect_refused(const std::string& command, const std::string& case_path, const std::string& key) {
  const fs::path dir = out_dir(command + "_" + fs::path(case_path).stem().string() + "_refused");
  const CliResult r = flapstab(command + " " + case_path + " -q -o " + dir.string());
  EXPECT_EQ(r.status, 2) << command << ": " << r.err;
  EXPECT_NE(r.err.find(key), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir)) << command;
}

TEST(Examples, CfdRefusesTheAbdomenButTakesTheHindPair) {
  // The CFD geometry is one rigid body: flapstab cfd refuses the abdomen before writing anything, and so does the
  // CFD model (the key: [aero] model).
  expect_refused("cfd", source + "/data/examples/abdomen_hawkmoth.toml", "abdomen");
  const std::string abdomen_cfd = testing::write_temp(
      "abdomen_cfd.toml", edited("data/examples/abdomen_hawkmoth.toml", {{"model = \"quasi-steady\"", "model = \"cfd\""}}));
  const std::string why = testing::expect_input_error([&] { load_case(abdomen_cfd); }, "aero.model", abdomen_cfd);
  EXPECT_NE(why.find("abdomen"), std::string::npos) << why;
  // A hind pair is in the CFD geometry (parts hind_right and hind_left; tests/apps/test_cfd_cli.cpp runs a
  // four-winged case): the four-winged example passes the geometry check that flapstab cfd makes of every case, and
  // loads with model = "cfd".
  const std::string four = source + "/data/examples/four_wing_hawkmoth.toml";
  EXPECT_NO_THROW(check_cfd_geometry(load_case(four).insect, four));
  // But the example's two pairs are one wing pair twice, at the same hinge and in phase: two coincident membranes,
  // which the immersed boundary does not model, so flapstab cfd refuses it at planning, naming the hind hinge.
  expect_refused("cfd", four, "hind_wing.hinge_m");
  const std::string four_cfd = testing::write_temp(
      "four_wing_cfd.toml", edited("data/examples/four_wing_hawkmoth.toml", {{"model = \"quasi-steady\"", "model = \"cfd\""}}));
  Case c;
  ASSERT_NO_THROW(c = load_case(four_cfd));
  EXPECT_EQ(c.aero.model, "cfd");
  EXPECT_TRUE(c.insect.hind_wing.has_value());
}

TEST(Examples, TranslationOnlyModelTrimsAndHasThreeExponents) {
  // flapstab floquet on [body_motion]: the translation-only cyclic trim converges through its two parameters and the
  // Floquet analysis is of [u, v, w].
  const std::string example = source + "/data/examples/translation_only_hawkmoth.toml";
  const fs::path dir = out_dir("translation_only");
  const CliResult r = flapstab("floquet " + example + " -q -o " + dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = json_of(dir / "floquet.json");
  EXPECT_EQ(j["model"], "translation-only");
  EXPECT_TRUE(j["cyclic_trim"]["converged"].get<bool>());
  EXPECT_LT(double(j["cyclic_trim"]["residual"]), 1e-10);
  EXPECT_EQ(j["cyclic_trim"]["parameters"].size(), 2u);
  EXPECT_EQ(j["state_order"], nlohmann::json({"u", "v", "w"}));
  EXPECT_EQ(j["exponents_nd"].size(), 3u);
  // The other commands refuse the case; so does the CFD model.
  for (const char* command : {"analyze", "trim-hover", "derivatives", "fly", "cfd"})
    expect_refused(command, example, "body_motion");
  expect_refused("floquet", testing::write_temp("translation_only_cfd.toml",
                                                edited("data/examples/translation_only_hawkmoth.toml",
                                                       {{"model = \"quasi-steady\"", "model = \"cfd\""}})),
                 "aero.model");
}

// cyclic_attitude = "free": the cyclic trim holds body_angle_deg and solves the two other parameters; the orbit's
// mean attitude is written (body angle + mean theta) and differs from the averaged trim's body angle (the hawkmoth's
// wingbeat-scale rocking moves it by about 0.08 deg; tests/trim/test_cyclic.cpp checks its value against the
// imposed-attitude trim).
TEST(Examples, FreeAttitudeCyclicTrimReportsTheMeanAttitude) {
  const fs::path dir = out_dir("free_attitude");
  const std::string example = source + "/data/examples/free_attitude_hawkmoth.toml";
  const CliResult r = flapstab("floquet " + example + " -q -o " + dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = json_of(dir / "floquet.json");
  const nlohmann::json& ct = j["cyclic_trim"];
  EXPECT_TRUE(ct["converged"].get<bool>());
  EXPECT_EQ(ct["attitude"], "free");
  EXPECT_EQ(ct["parameters"].size(), 2u);
  EXPECT_FALSE(ct["residuals"].contains("mean_theta"));
  const double chi = double(ct["kinematics"]["body_angle_deg"]), mean = double(ct["mean_body_angle_deg"]);
  EXPECT_NEAR(mean, chi + double(ct["mean_theta_rad"]) * 180 / M_PI, 1e-12);
  EXPECT_GT(std::abs(mean - chi), 0.01);
  EXPECT_LT(std::abs(mean - chi), 1.0);
}

// Abdominal flexion as the pitch controller's actuator: analyze reports its control derivative (a ventral flexion
// moves the CoM forward: nose-down, M < 0, no force) and the delayed loop's critical latency; the loop stabilises
// for some latency (critical latency > 0) but not at the case's 41 ms.
TEST(Examples, AbdominalFlexionDrivesThePitchController) {
  const nlohmann::json j = analyze("abdomen_control_hawkmoth.toml");
  ASSERT_FALSE(j.is_null());
  const nlohmann::json& c = j["control"];
  EXPECT_NE(c["description"].get<std::string>().find("abdomen_flexion_deg"), std::string::npos) << c;
  EXPECT_GT(double(c["critical_latency_s"]), 0.005);
  EXPECT_LT(double(c["critical_latency_s"]), 0.041);
  EXPECT_GT(double(c["periodic_spectral_radius"]["closed_loop"]), 1.0);
  const std::string report = slurp(fs::path(testing::write_temp("x", "")).parent_path() / "example_abdomen_control_hawkmoth.toml" / "report.md");
  EXPECT_NE(report.find("Control derivatives of abdomen_flexion_deg"), std::string::npos);
}

TEST(Examples, MinimumPowerTrimCostsLessThanTheLeastChangeTrim) {
  const nlohmann::json m = trim(source + "/data/examples/min_power_hawkmoth.toml");
  const nlohmann::json f = trim(source + "/data/insects/hawkmoth.toml");
  ASSERT_FALSE(m.is_null() || f.is_null());
  EXPECT_EQ(m["trim"]["objective"], "min-power");
  EXPECT_LT(double(m["trim"]["mean_aerodynamic_power_W"]), double(f["trim"]["mean_aerodynamic_power_W"]));
}

TEST(Examples, NloptTrimAgreesWithIpopt) {
  const nlohmann::json n = trim(source + "/data/examples/nlopt_hawkmoth.toml");
  const nlohmann::json f = trim(source + "/data/insects/hawkmoth.toml");
  ASSERT_FALSE(n.is_null() || f.is_null());
  EXPECT_EQ(n["trim"]["solver"], "nlopt");
  for (std::size_t i = 0; i < 3; ++i)  // a square system: one solution near the start
    EXPECT_NEAR(double(n["trim"]["parameters"][i]["value"]), double(f["trim"]["parameters"][i]["value"]), 1e-3);
}

TEST(Examples, AsymmetricWingsTrimAllSixLoads) {
  const nlohmann::json j = analyze("asymmetric_hawkmoth.toml");
  ASSERT_FALSE(j.is_null());
  EXPECT_EQ(j["trim"]["parameters"].size(), 6u);
  EXPECT_TRUE(j["trim"]["converged"].get<bool>());
}

TEST(Examples, FlusiKinematicsFile) {
  const nlohmann::json j = analyze("flusi_fruitfly.toml");
  ASSERT_FALSE(j.is_null());
  EXPECT_TRUE(j["trim"]["converged"].get<bool>());
}

TEST(Examples, CfdCaseDryRun) {
  for (const char* name : {"hawkmoth_cfd.toml", "fruitfly_cfd.toml", "bumblebee_cfd.toml"}) {
    const CliResult r = flapstab("cfd " + source + "/data/cases/" + name + " --dry-run");
    EXPECT_EQ(r.status, 0) << name << ": " << r.err;
    EXPECT_NE(r.err.find("estimate (timed on the first 2 steps)"), std::string::npos) << r.err;
  }
}

// The force-partitioning examples (hawkmoth at Re = 1000, fruit fly at Re = 100): a dry run plans the grid, times two
// steps and one partition (the cost estimate) and writes nothing.
TEST(Examples, ForcePartitioningDryRuns) {
  for (const char* name : {"fpm_hawkmoth_cfd.toml", "fpm_fruitfly_cfd.toml"}) {
    const std::string file = source + "/data/examples/" + name;
    const fs::path dir = out_dir("fpm_dry");
    const CliResult r = flapstab("cfd " + file + " --dry-run -o " + dir.string());
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("force partitioning:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("x the cost of the run without"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "fpm.csv"));
  }
}

// The free-flight example under the Navier-Stokes model (its full run is recorded in docs/validation.md): open loop,
// a perturbation from the hover, and a plan whose fine box leaves at least half a wing length of room beyond the
// swept volume on every side (the body's drift over its wingbeats).
TEST(Examples, FreeFlightCfdExamplePlansWithRoomToDrift) {
  const Case c = load_case(source + "/data/examples/fly_hawkmoth_cfd.toml");
  EXPECT_EQ(c.aero.model, "cfd");
  EXPECT_EQ(c.control.type, "none");
  EXPECT_EQ(c.flight.start, "periodic-orbit");
  ASSERT_FALSE(c.flight.perturbation.empty());
  const ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  const double R = c.insect.wing.length;
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(plan.swept_lo(a) - plan.fine_lo(a), 0.5 * R) << a;
    EXPECT_GE(plan.fine_hi(a) - plan.swept_hi(a), 0.5 * R) << a;
  }
}

// The example's commented closed-loop pair (recorded in docs/validation.md as holding the coupled CFD insect's pitch)
// lies inside the quasi-steady control map's stable region, as the comment says: the example with the block
// uncommented and model = "quasi-steady" gives a stable averaged and periodic loop for the case's controller.
TEST(Examples, FreeFlightCfdExampleClosedLoopPairIsStableInTheQuasiSteadyMap) {
  std::string text = slurp(source + "/data/examples/fly_hawkmoth_cfd.toml");
  const std::size_t at = text.find("# [control]\n");
  ASSERT_NE(at, std::string::npos);
  std::string block = text.substr(at), uncommented;
  std::stringstream lines(block);
  for (std::string line; std::getline(lines, line);)
    uncommented += (line.rfind("# ", 0) == 0 ? line.substr(2) : line) + "\n";
  text = text.substr(0, at) + uncommented;
  const std::string cfd_model = "model = \"cfd\"";
  const std::size_t m = text.find(cfd_model);
  ASSERT_NE(m, std::string::npos);
  text.replace(m, cfd_model.size(), "model = \"quasi-steady\"");
  text += "[control.map]\ngains = 6\nlatencies = 6\nperiodic_gains = 2\nperiodic_latencies = 2\ncheck_points = 0\n";
  const fs::path dir = out_dir("fly_cfd_pair");
  const fs::path file = dir / "case.toml";
  fs::create_directories(dir);
  std::ofstream(file) << text;
  const CliResult r = flapstab("control-map " + file.string() + " -o " + dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = json_of(dir / "control_map.json");
  const auto& cc = j["case_controller"];
  EXPECT_NE(std::string(cc["description"]).find("stroke_mean_deg: 1 deg/deg of pitch after 2 ms"), std::string::npos)
      << cc.dump();
  EXPECT_TRUE(cc["stable_lti"].get<bool>()) << cc.dump();
  EXPECT_TRUE(cc["stable_periodic"].get<bool>()) << cc.dump();
}

// A table in the wingbeat convention with m+, I+, g+ (docs/derivative-table.md's worked example): the unstable
// oscillatory mode at lambda T = 0.05453 +- 0.11595i, as the guide prints it (4 figures).
TEST(Examples, DerivativeTableInTheWingbeatConvention) {
  const fs::path dir = out_dir("table");
  const CliResult r = flapstab("stability --derivatives " + source + "/data/examples/derivative_table_bumblebee.toml" +
                               " --model longitudinal -q -o " + dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = json_of(dir / "stability.json");
  bool found = false;
  for (const auto& m : j["stability"]["modes"]) {
    const double re = m["eigenvalue_per_wingbeat"][0], im = m["eigenvalue_per_wingbeat"][1];
    if (im > 0) {
      found = true;
      EXPECT_NEAR(re, 0.05453, 5e-5);
      EXPECT_NEAR(im, 0.11595, 5e-5);
    }
  }
  EXPECT_TRUE(found) << j.dump();
}

// Every example is listed in the user guide and run above (the names in this file).
TEST(Examples, EveryExampleIsListedAndRun) {
  const std::string guide = slurp(source + "/docs/user-guide.md"), self = slurp(source + "/tests/apps/test_examples.cpp");
  int n = 0;
  for (const auto& e : fs::directory_iterator(source + "/data/examples")) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".toml") continue;
    ++n;
    EXPECT_NE(guide.find("data/examples/" + name), std::string::npos) << name << " is not in docs/user-guide.md";
    const bool run = self.find("\"" + name + "\"") != std::string::npos ||
                     self.find("/data/examples/" + name + "\"") != std::string::npos;
    EXPECT_TRUE(run) << name << " is not run by this test";
  }
  EXPECT_GE(n, 6);
}

}  // namespace
}  // namespace flapstab
