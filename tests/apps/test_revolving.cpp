// Tests for the revolving-wing flyer: the case-file option, its kinematics and its comparison with
// the flapping flyer (same weight, same mean stroke speed).
#include <gtest/gtest.h>
#include "apps/revolving.hpp"
#include "cfd/aero_factory.hpp"
#include "common/case_text.hpp"
#include "core/errors.hpp"

namespace flapstab {
namespace {

using testing::replace;
using testing::valid_case_text;
using testing::write_temp;

std::string revolving_text() {
  std::string t = valid_case_text();
  t = t.substr(0, t.find("[kinematics.stroke]")) + t.substr(t.find("[fluid]"));
  t = replace(t, "body_angle_deg = 40.0", "body_angle_deg = 40.0\ntype = \"revolving\"\npitch_deg = 35.0");
  t = t.substr(0, t.find("[[trim.parameter]]")) +
      "[[trim.parameter]]\nname = \"frequency_hz\"\nlower = 5.0\nupper = 60.0\n"
      "[[trim.parameter]]\nname = \"body_angle_deg\"\nlower = 0.0\nupper = 80.0\n"
      "[[trim.parameter]]\nname = \"stroke_plane_deg\"\nlower = -30.0\nupper = 30.0\n";
  return t;
}

TEST(Revolving, CaseFileOptionGivesConstantStrokeVelocityAndFixedPitch) {
  const Case c = load_case(write_temp("rev.toml", revolving_text()));
  const Kinematics& k = c.kinematics;
  ASSERT_TRUE(k.revolving());
  const double n = k.frequency_hz;
  for (double t : {0.0, 0.3 / n, 0.77 / n}) {
    const WingAngleState a = k.angles(Side::right, t);
    EXPECT_NEAR(a.dphi, 2 * pi * n, 1e-9);  // one revolution per cycle
    EXPECT_EQ(a.ddphi, 0.0);
    EXPECT_NEAR(a.alpha, 35 * deg, 1e-15);
    EXPECT_EQ(a.dalpha, 0.0);
  }
  // 2 Phi n r2 is the wing's speed at r2.
  EXPECT_NEAR(2 * k.stroke_amplitude() * n, 2 * pi * n, 1e-12);
}

TEST(Revolving, FlappingParametersAreRefused) {
  std::string t = revolving_text();
  t = replace(t, "name = \"body_angle_deg\"", "name = \"stroke_mean_deg\"");
  const Case c = load_case(write_temp("rev_bad.toml", t));
  const auto model = make_aero_model(c);
  EXPECT_THROW(trim_hover(c, *model), InputError);
  EXPECT_THROW(load_case(write_temp("rev_bad2.toml", replace(revolving_text(), "pitch_deg = 35.0", "pitch_deg = 120.0"))),
               InputError);
}

// The equivalent revolving flyer of the trimmed flapping test insect: same weight supported, same
// reference speed U = 2 Phi n r2 (equal mean stroke speed at the start of its trim).
TEST(Revolving, EquivalentFlyerTrimsAndKeepsTheMeanSpeed) {
  const Case flap = load_case(write_temp("flap.toml", valid_case_text()));
  const auto model = make_aero_model(flap);
  const TrimResult t = trim_hover(flap, *model);
  ASSERT_TRUE(t.converged);
  const Case rev = revolving_equivalent(flap, t.kinematics);
  EXPECT_NEAR(2 * rev.kinematics.stroke_amplitude() * rev.kinematics.frequency_hz,
              2 * t.kinematics.stroke_amplitude() * t.kinematics.frequency_hz, 1e-9);
  const RevolvingComparison r = compare_with_revolving(flap, t.kinematics, *model);
  EXPECT_TRUE(r.trim.converged);
  EXPECT_LT(r.trim.relative_force_residual, 1e-8);
  EXPECT_LT(r.trim.relative_moment_residual, 1e-8);
  ASSERT_TRUE(r.stability.longitudinal);
  EXPECT_EQ(r.stability.longitudinal->modes.size(), 3u);
}

}  // namespace
}  // namespace flapstab
