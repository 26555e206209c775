// Tests for core/kinematics: time derivatives from the phase series, symmetry and amplitude.
#include <gtest/gtest.h>
#include "common/test_insect.hpp"
#include "core/kinematics.hpp"

namespace flapstab {
namespace {

TEST(Kinematics, AnglesAndRatesInRadiansAndSeconds) {
  const Kinematics k = testing::harmonic_kinematics(25.0, 120.0, 35.0);
  // phi = -60 deg cos(2 pi n t): at t = T/4, phi = 0 and dphi/dt = 60 deg * 2 pi n.
  const WingAngleState a = k.angles(Side::right, 0.25 / 25.0);
  EXPECT_NEAR(a.phi, 0.0, 1e-15);
  EXPECT_NEAR(a.dphi, 60 * deg * 2 * pi * 25.0, 1e-9);
  EXPECT_NEAR(a.alpha, 35 * deg, 1e-14);  // mid-downstroke incidence
  EXPECT_NEAR(k.angles(Side::right, 0.75 / 25.0).alpha, 145 * deg, 1e-14);
  EXPECT_NEAR(k.stroke_amplitude(), 120 * deg, 1e-6);
  EXPECT_NEAR(k.period(), 0.04, 1e-15);
}

TEST(Kinematics, SymmetryDetection) {
  Kinematics k = testing::harmonic_kinematics();
  EXPECT_TRUE(k.symmetric());
  k.left.stroke.shift(1e-6);
  EXPECT_FALSE(k.symmetric());
}

}  // namespace
}  // namespace flapstab
