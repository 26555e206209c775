// Tests for cfd/aero_factory: the case's [aero] selects the model; an unknown model is an input error.
#include <gtest/gtest.h>
#include <cmath>
#include <cstdio>
#include <string>
#include "cfd/aero_factory.hpp"
#include "common/case_text.hpp"
#include "core/errors.hpp"

namespace flapstab {
namespace {

std::string fmt_double(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

TEST(AeroFactory, SelectsTheQuasiSteadyCoefficientSet) {
  Case c = load_case(testing::write_temp("f.toml", testing::valid_case_text()));
  EXPECT_EQ(make_aero_model(c)->name(), "quasi-steady (robofly)");
  c.aero.quasi_steady.coefficients = "berman-wang";
  EXPECT_EQ(make_aero_model(c)->name(), "quasi-steady (berman-wang)");
  EXPECT_TRUE(make_aero_model(c)->is_instantaneous());
}

// [aero.quasi_steady] constants from the case file reach the model: the published Robofly constants spelled out
// give the default loads bit for bit; other constants, a table, the rotational coefficient and the centre of
// pressure change them.
TEST(AeroFactory, QuasiSteadyConstantsFromTheCaseFile) {
  const std::string base = testing::valid_case_text();
  const std::string published = testing::replace(
      base, "blade_elements = 40\n",
      "blade_elements = 40\n[aero.quasi_steady.robofly]\nlift_mean = 0.225\nlift_amplitude = 1.58\nlift_rate = 2.13\n"
      "lift_offset_deg = 7.20\ndrag_mean = 1.92\ndrag_amplitude = 1.55\ndrag_rate = 2.04\ndrag_offset_deg = 9.82\n");
  const Case c0 = load_case(testing::write_temp("qs0.toml", base));
  const Case c1 = load_case(testing::write_temp("qs1.toml", published));
  const Case c2 = load_case(testing::write_temp("qs2.toml", testing::replace(published, "lift_amplitude = 1.58",
                                                                             "lift_amplitude = 1.4")));
  const Case c3 = load_case(testing::write_temp(
      "qs3.toml", testing::replace(base, "blade_elements = 40\n",
                                   "blade_elements = 40\nrotational_coefficient = 1.2\n"
                                   "centre_of_pressure_chord_fraction = 0.4\n")));
  ASSERT_TRUE(c3.aero.quasi_steady.rotational_coefficient.has_value());
  EXPECT_EQ(*c3.aero.quasi_steady.rotational_coefficient, 1.2);
  EXPECT_EQ(c3.aero.quasi_steady.centre_of_pressure, 0.4);
  auto loads = [](const Case& c) {
    return make_aero_model(c)->run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{}).mean();
  };
  const Wrench w0 = loads(c0), w1 = loads(c1), w2 = loads(c2);
  EXPECT_EQ((w0.force - w1.force).norm(), 0.0);
  EXPECT_EQ((w0.moment - w1.moment).norm(), 0.0);
  EXPECT_GT((w0.force - w2.force).norm(), 1e-3 * w0.force.norm());
  // The rotational force and the chordwise lever act within the wingbeat (their cycle means nearly cancel between
  // half strokes of this symmetric hover): compare one instant.
  auto at = [](const Case& c) {
    return make_aero_model(c)->run(c.insect, c.kinematics, BodyMotion{}, AeroRunOptions{}).samples[10].total();
  };
  const Wrench i0 = at(c0), i3 = at(c3);
  EXPECT_GT((i0.force - i3.force).norm(), 1e-3 * i0.force.norm());
  EXPECT_GT((i0.moment - i3.moment).norm(), 1e-3 * i0.force.norm() * c0.insect.wing.mean_chord);
  // A table: the Berman-Wang forms sampled at 0, 30, 60, 90 deg and 1-deg steps reproduces that set (interpolation
  // error h^4 max|f^(4)| / 27 <= 9.3e-8 for h = 1 deg, tests/cfd/test_quasi_steady.cpp; 1e-6 of the force here).
  std::string alpha, lift, drag;
  for (int i = 0; i <= 90; ++i) {
    const double a = i * 3.14159265358979323846 / 180;
    const std::string sep = i ? ", " : "";
    alpha += sep + std::to_string(i);
    lift += sep + fmt_double(1.678 * std::sin(2 * a));
    drag += sep + fmt_double(0.07 * std::cos(a) * std::cos(a) + 3.06 * std::sin(a) * std::sin(a));
  }
  const std::string bw = testing::replace(base, "coefficients = \"robofly\"", "coefficients = \"berman-wang\"");
  const std::string table = testing::replace(base, "coefficients = \"robofly\"\nblade_elements = 40\n",
                                             "coefficients = \"table\"\nblade_elements = 40\n[aero.quasi_steady.table]\n"
                                             "alpha_deg = [" + alpha + "]\nlift = [" + lift + "]\ndrag = [" + drag + "]\n");
  const Case cb = load_case(testing::write_temp("qsb.toml", bw)), ct = load_case(testing::write_temp("qst.toml", table));
  EXPECT_EQ(make_aero_model(ct)->name(), "quasi-steady (table)");
  const Wrench wb = loads(cb), wt = loads(ct);
  EXPECT_LT((wb.force - wt.force).norm(), 1e-6 * wb.force.norm());
}

TEST(AeroFactory, SelectsTheNavierStokesModel) {
  Case c = load_case(testing::write_temp("f2.toml", testing::valid_case_text()));
  c.aero.model = "cfd";
  const auto m = make_aero_model(c);
  EXPECT_EQ(m->name(), "navier-stokes-ib");
  EXPECT_FALSE(m->is_instantaneous());
}

TEST(AeroFactory, UnknownModelIsAnInputError) {
  Case c = load_case(testing::write_temp("f3.toml", testing::valid_case_text()));
  c.aero.model = "panel";
  try {
    make_aero_model(c);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "aero.model");
  }
}

}  // namespace
}  // namespace flapstab
