// Tests for core/rotation: right-handed active rotations, Euler 3-2-1, skew matrices, mirror.
#include <gtest/gtest.h>
#include "core/rotation.hpp"

namespace flapstab {
namespace {

TEST(Rotation, RightHandedActiveRotations) {
  EXPECT_LT((rot_z(pi / 2) * Vec3::UnitX() - Vec3::UnitY()).norm(), 1e-15);
  EXPECT_LT((rot_x(pi / 2) * Vec3::UnitY() - Vec3::UnitZ()).norm(), 1e-15);
  EXPECT_LT((rot_y(pi / 2) * Vec3::UnitZ() - Vec3::UnitX()).norm(), 1e-15);
  // Nose-up pitch in z-down axes: x tilts towards -z.
  EXPECT_LT(rot_y(0.3).col(0).z(), 0.0);
}

TEST(Rotation, Euler321AndSkew) {
  const Mat3 R = euler321(0.1, -0.2, 0.7);
  EXPECT_LT((R * R.transpose() - Mat3::Identity()).norm(), 1e-15);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-15);
  EXPECT_LT((R - rot_z(0.7) * rot_y(-0.2) * rot_x(0.1)).norm(), 1e-15);
  const Vec3 a(1, -2, 3), b(0.5, 4, -1);
  EXPECT_LT((skew(a) * b - a.cross(b)).norm(), 1e-15);
  EXPECT_NEAR(mirror_y().determinant(), -1.0, 0.0);
}

}  // namespace
}  // namespace flapstab
