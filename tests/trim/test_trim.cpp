// Tests for trim/: the cycle-averaged hover trim (Ipopt and NLopt), its parameters and its failures.
#include <gtest/gtest.h>
#include <cmath>
#include <sstream>
#include <tuple>
#include <vector>
#include "cfd/aero_factory.hpp"
#include "common/case_text.hpp"
#include "common/expect_error.hpp"
#include "core/errors.hpp"
#include "trim/parameters.hpp"
#include "trim/trim.hpp"

namespace flapstab {
namespace {

using testing::replace;
using testing::valid_case_text;
using testing::write_temp;

// The case of this text (written to a temporary file `name`) and its trim with the case's own model.
struct TrimmedCase {
  Case c;
  TrimResult t;
};
TrimmedCase trim_text(const std::string& name, const std::string& text) {
  TrimmedCase r{load_case(write_temp(name, text)), {}};
  r.t = trim_hover(r.c, *make_aero_model(r.c));
  return r;
}

// [[trim.parameter]] entries (name, lower, upper) as case-file text.
std::string trim_parameters_text(const std::vector<std::tuple<std::string, double, double>>& parameters) {
  std::ostringstream t;
  t.precision(17);
  for (const auto& [name, lower, upper] : parameters)
    t << "[[trim.parameter]]\nname = \"" << name << "\"\nlower = " << lower << "\nupper = " << upper << "\n";
  return t.str();
}

// The acceptance: force residual < 1e-8 of the weight, moment < 1e-8 of weight x R.
TEST(Trim, IpoptBalancesWeightAndMoments) {
  const TrimResult t = trim_text("trim.toml", valid_case_text()).t;
  ASSERT_TRUE(t.converged) << t.message;
  EXPECT_LT(t.relative_force_residual, 1e-8);
  EXPECT_LT(t.relative_moment_residual, 1e-8);
  EXPECT_EQ(t.equations.size(), 3u);
  // Symmetric insect: lateral components vanish identically.
  EXPECT_LT(std::abs(t.force_residual.y()), 1e-12 * t.weight);
  EXPECT_GT(t.mean_power, 0.0);
  for (const auto& p : t.parameters) {
    EXPECT_GE(p.value, p.lower);
    EXPECT_LE(p.value, p.upper);
  }
}

TEST(Trim, NloptReachesTheSameTrim) {
  const std::string text = replace(replace(valid_case_text(), "solver = \"ipopt\"", "solver = \"nlopt\""),
                                   "tolerance = 1e-10", "tolerance = 1e-9");
  const TrimResult t = trim_text("trim_nlopt.toml", text).t;
  ASSERT_TRUE(t.converged) << t.message << " residuals " << t.relative_force_residual << " "
                           << t.relative_moment_residual;
  const TrimResult ti = trim_text("trim_ipopt.toml", valid_case_text()).t;
  // A square system has one solution near the start: both solvers must find it (to 1e-5 deg).
  for (std::size_t i = 0; i < t.parameters.size(); ++i)
    EXPECT_NEAR(t.parameters[i].value, ti.parameters[i].value, 1e-5) << t.parameters[i].name;
}

TEST(Trim, InfeasibleBoundsAreReportedNotConverged) {
  // The stroke amplitude needed is far above 62 deg: no trim inside these bounds.
  const std::string text = replace(valid_case_text(), "lower = 60.0\nupper = 170.0", "lower = 60.0\nupper = 62.0");
  const std::string text2 = replace(text, "cos_deg = [-60.0]", "cos_deg = [-30.5]");
  const TrimResult t = trim_text("infeasible.toml", text2).t;
  EXPECT_FALSE(t.converged);
  EXPECT_GT(t.relative_force_residual, 1e-3);
}

TEST(Trim, TooFewParametersIsAnInputError) {
  std::string text = valid_case_text();
  text = text.substr(0, text.find("[[trim.parameter]]\nname = \"stroke_mean_deg\""));
  EXPECT_THROW(trim_text("few.toml", text), InputError);
}

TEST(Trim, MinimumPowerNeverCostsMoreThanLeastChange) {
  // With the pitch amplitude (incidence) free as a fourth parameter, the least-change trim is feasible
  // for the min-power problem, so the min-power optimum can only be lower; the quasi-steady lift-to-drag
  // ratio favours lower incidence, so it is markedly lower (>10 %).
  const std::string text = valid_case_text() + trim_parameters_text({{"pitch_amplitude_deg", 60.0, 160.0}});
  const TrimResult a = trim_text("lc.toml", text).t, b = trim_text("mp.toml", replace(text, "least-change", "min-power")).t;
  ASSERT_TRUE(a.converged) << a.message;
  ASSERT_TRUE(b.converged) << b.message;
  EXPECT_LT(b.mean_power, 0.9 * a.mean_power);
}

TEST(TrimParameters, InitialValuesReproduceTheBaseAndAmplitudesScale) {
  const Case c = load_case(write_temp("par.toml", valid_case_text()));
  const TrimParameterization p(c.kinematics, c.trim.parameters, c.path);
  EXPECT_NEAR(p.initial()[0], 120.0, 1e-9);
  EXPECT_NEAR(p.initial()[2], 90.0, 1e-12);
  const Kinematics same = p.apply(p.initial());
  EXPECT_NEAR(same.right.stroke.eval(0.3).f, c.kinematics.right.stroke.eval(0.3).f, 1e-15);
  const Kinematics k = p.apply({100.0, 5.0, 95.0});
  EXPECT_NEAR(exact_peak_to_peak(k.right.stroke) / deg, 100.0, 1e-9);
  EXPECT_NEAR(k.left.stroke.mean() / deg, 5.0, 1e-12);
  EXPECT_NEAR(k.right.pitch.mean() / deg, 95.0, 1e-12);
}

// Berman & Wang (2007) angle forms: their shape and phase parameters are trim parameters.
std::string berman_wang_trim_text(const std::string& parameters) {
  // Phi = 100 deg: the squarer stroke carries the weight at a smaller amplitude than the cosine's 120 deg; no
  // deviation to begin with.
  const std::string t = replace(replace(testing::berman_wang_case_text(), "amplitude_deg = 60.0", "amplitude_deg = 50.0"),
                                "amplitude_deg = 4.0", "amplitude_deg = 0.0");
  return t.substr(0, t.find("[[trim.parameter]]")) + parameters;
}

TEST(TrimParameters, BermanWangParametersSetTheirForms) {
  const Case c = load_case(write_temp("bw_par.toml", berman_wang_trim_text(trim_parameters_text({{"stroke_shape_k", 0.1, 0.95},
                                                                   {"pitch_shape_c", 0.5, 10.0},
                                                                   {"pitch_phase_deg", -30.0, 30.0},
                                                                   {"deviation_amplitude_deg", 0.0, 20.0},
                                                                   {"deviation_phase_deg", -90.0, 90.0},
                                                                   {"stroke_amplitude_deg", 60.0, 170.0}}))));
  const TrimParameterization p(c.kinematics, c.trim.parameters, c.path);
  const std::vector<double> expected0 = {0.7, 2.4, 0.0, 0.0, 0.0, 100.0};
  for (std::size_t i = 0; i < expected0.size(); ++i) EXPECT_NEAR(p.initial()[i], expected0[i], 1e-12) << i;
  EXPECT_EQ(TrimParameterization::unit("stroke_shape_k"), "1");
  const Kinematics k = p.apply({0.4, 5.0, 10.0, 8.0, 20.0, 100.0});
  for (const WingAngles* w : {&k.right, &k.left}) {
    EXPECT_DOUBLE_EQ(w->stroke.berman_wang()->shape, 0.4);
    EXPECT_DOUBLE_EQ(w->pitch.berman_wang()->shape, 5.0);
    EXPECT_NEAR(w->pitch.berman_wang()->phase / deg, 10.0, 1e-12);
    EXPECT_NEAR(w->deviation.berman_wang()->amplitude / deg, 4.0, 1e-12);  // half the peak-to-peak
    EXPECT_NEAR(w->deviation.berman_wang()->phase / deg, 20.0, 1e-12);
    EXPECT_NEAR(exact_peak_to_peak(w->stroke) / deg, 100.0, 1e-12);
  }
}

TEST(TrimParameters, BermanWangParameterOfAFourierAngleIsAnInputError) {
  const std::string text = replace(valid_case_text(), "name = \"pitch_mean_deg\"", "name = \"pitch_shape_c\"");
  const Case c = load_case(write_temp("bw_par_bad.toml", text));
  EXPECT_THROW(TrimParameterization(c.kinematics, c.trim.parameters, c.path), InputError);
  const Case k = load_case(
      write_temp("bw_par_bad_k.toml", berman_wang_trim_text(trim_parameters_text({{"stroke_shape_k", 0.1, 1.0}}))));
  testing::expect_input_error([&] { TrimParameterization(k.kinematics, k.trim.parameters, k.path); },
                              "trim.parameter[0].lower");
}

// A hover trim through the shape of the Berman-Wang stroke: K (with the stroke and pitch means) balances the
// weight and the pitching moment to the trim's acceptance (1e-8 of the weight and of weight x R).
TEST(Trim, BermanWangShapeIsATrimParameter) {
  const TrimResult t = trim_text("bw_trim.toml", berman_wang_trim_text(trim_parameters_text(
                                                      {{"stroke_shape_k", 0.05, 0.98},
                                                       {"stroke_mean_deg", -40.0, 40.0},
                                                       {"pitch_mean_deg", 60.0, 120.0}}))).t;
  ASSERT_TRUE(t.converged) << t.message;
  EXPECT_LT(t.relative_force_residual, 1e-8);
  EXPECT_LT(t.relative_moment_residual, 1e-8);
  EXPECT_NE(t.parameters[0].value, 0.7);
}

// [environment] gravity_m_s2: doubling gravity doubles the weight the trim balances. Every quasi-steady load at fixed
// wing angles scales as the frequency squared (translational ~ U^2, rotational ~ alphadot U, added mass ~ dU/dt; the
// body at rest), so the trim through the frequency (with the stroke and pitch means) must land on sqrt(2) times the
// frequency with the same means - to the trim's tolerance (analytic similarity; 1e-8 relative here).
TEST(Trim, DoubledGravityNeedsTheWeightDoublingForce) {
  const std::string base = replace(replace(valid_case_text(), "name = \"stroke_amplitude_deg\"\nlower = 60.0\nupper = 170.0",
                                           "name = \"frequency_hz\"\nlower = 10.0\nupper = 80.0"),
                                   "[fluid]\n", "[environment]\ngravity_m_s2 = G\n\n[fluid]\n");
  auto trimmed = [&](const std::string& g) {
    const TrimResult t = trim_text("gravity_" + g + ".toml", replace(base, "gravity_m_s2 = G", "gravity_m_s2 = " + g)).t;
    EXPECT_TRUE(t.converged) << t.message;
    return t;
  };
  const TrimResult one = trimmed("9.80665"), two = trimmed("19.6133");
  ASSERT_EQ(one.parameters[0].name, "frequency_hz");
  EXPECT_NEAR(two.weight, 2 * one.weight, 1e-15 * two.weight);
  EXPECT_NEAR(two.parameters[0].value / one.parameters[0].value, std::sqrt(2.0), 1e-8);
  EXPECT_NEAR(two.parameters[1].value, one.parameters[1].value, 1e-6);  // stroke mean, deg
  EXPECT_NEAR(two.parameters[2].value, one.parameters[2].value, 1e-6);  // pitch mean, deg
  EXPECT_LT(two.relative_force_residual, 1e-8);
}

TEST(Trim, GravityOutsideItsRangeIsAnInputError) {
  for (const char* g : {"0.0", "-9.8", "9806.65"}) {
    const std::string path = write_temp("gravity_bad.toml", replace(valid_case_text(), "[fluid]\n",
                                                                     std::string("[environment]\ngravity_m_s2 = ") + g +
                                                                         "\n[fluid]\n"));
    testing::expect_input_error([&] { load_case(path); }, "environment.gravity_m_s2", path);
  }
}

}  // namespace
}  // namespace flapstab
