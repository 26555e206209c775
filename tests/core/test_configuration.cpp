// Tests for core/configuration: mirror symmetry, the mean-CoM reference point, and wing point
// velocities/accelerations consistent with positions (finite differences in time).
#include <gtest/gtest.h>
#include "common/test_insect.hpp"
#include "core/configuration.hpp"
#include "core/rotation.hpp"

namespace flapstab {
namespace {

TEST(Configuration, LeftWingIsMirrorImageForSymmetricKinematics) {
  const Insect ins = testing::test_insect();
  const Kinematics k = testing::harmonic_kinematics();
  const Configuration cfg(ins, k);
  const Mat3 M = mirror_y();
  for (double t : {0.0, 0.007, 0.021}) {
    const WingPose r = cfg.wing_pose(Side::right, t), l = cfg.wing_pose(Side::left, t);
    const Vec3 xi(0.003, 0.03, 0.0);
    EXPECT_LT((l.position(xi) - M * r.position(xi)).norm(), 1e-15);
    EXPECT_LT((l.velocity(xi) - M * r.velocity(xi)).norm(), 1e-12);
    EXPECT_LT((l.acceleration(xi) - M * r.acceleration(xi)).norm(), 1e-9);
  }
  // The mean CoM lies in the plane of symmetry.
  EXPECT_NEAR(cfg.reference_point().y(), 0.0, 1e-18);
}

TEST(Configuration, ReferencePointIsTheCycleMeanCentreOfMass) {
  const Insect ins = testing::test_insect();
  const Kinematics k = testing::harmonic_kinematics();
  const Configuration cfg(ins, k);
  Vec3 mean = Vec3::Zero();
  const int n = 1000;
  for (int i = 0; i < n; ++i) mean += cfg.mass_state(k.period() * i / n).first_moment();
  EXPECT_LT((mean / n).norm() / ins.total_mass(), 1e-12);
}

TEST(Configuration, PointKinematicsMatchFiniteDifferences) {
  const Insect ins = testing::test_insect();
  Kinematics k = testing::harmonic_kinematics(26, 120, 35, 40, 15);
  k.right.deviation = FourierSeries{0.05, {0.0, 0.1}, {0.03, 0.0}};
  k.left = testing::harmonic_wing(100, 40, 5, 3);
  const Configuration cfg(ins, k);
  const Vec3 xi(0.004, 0.02, 0.0);
  const double h = 1e-7;
  for (Side s : {Side::right, Side::left}) {
    for (double t : {0.003, 0.017}) {
      const WingPose p = cfg.wing_pose(s, t), pp = cfg.wing_pose(s, t + h), pm = cfg.wing_pose(s, t - h);
      const Vec3 v_fd = (pp.position(xi) - pm.position(xi)) / (2 * h);
      const Vec3 a_fd = (pp.velocity(xi) - pm.velocity(xi)) / (2 * h);
      // Velocities ~ 10 m/s, accelerations ~ 1e4 m/s^2; central-difference error O(h^2).
      EXPECT_LT((p.velocity(xi) - v_fd).norm(), 1e-6 * p.velocity(xi).norm());
      EXPECT_LT((p.acceleration(xi) - a_fd).norm(), 1e-5 * p.acceleration(xi).norm());
      const Vec3 wd_fd = (pp.omega - pm.omega) / (2 * h);
      EXPECT_LT((p.omega_dot - wd_fd).norm(), 1e-5 * p.omega_dot.norm());
    }
  }
}

TEST(Configuration, StrokeAngleMovesTheRightWingForwardAndPitchRaisesTheLeadingEdge) {
  Insect ins = testing::test_insect();
  ins.wing.hinge = Vec3::Zero();
  Kinematics k = testing::harmonic_kinematics(26, 0, 35, 0, 0);
  k.right.stroke = FourierSeries{30 * deg, {}, {}};
  k.right.pitch = FourierSeries{30 * deg, {}, {}};
  k.right.deviation = FourierSeries{10 * deg, {}, {}};
  k.left = k.right;
  const WingPose p = Configuration(ins, k).wing_pose(Side::right, 0.0);
  const Vec3 span = p.axes.col(1), chord = p.axes.col(0);
  EXPECT_GT(span.x(), 0.4);    // towards the head
  EXPECT_LT(span.z(), -0.1);   // dorsal (up) for positive deviation
  EXPECT_LT(chord.z(), -0.4);  // leading edge up
  const WingPose q = Configuration(ins, k).wing_pose(Side::left, 0.0);
  EXPECT_GT(q.axes.col(1).x(), 0.4);
  EXPECT_LT(q.axes.col(1).y(), 0.0);
}

}  // namespace
}  // namespace flapstab

namespace flapstab {
namespace {

// Stroke plane fixed to the body ([kinematics] stroke_plane_reference = "body"): the stroke-plane frame is S pitched
// by chi + beta, so (1) it equals the horizontal reference with beta + chi, and (2) changing the body angle leaves
// every wing's pose relative to the body (A axes, about the body CoM) unchanged - to round-off (1e-15).
TEST(Configuration, StrokePlaneFixedToTheBodyTurnsWithIt) {
  const Insect ins = testing::test_insect();
  Kinematics body = testing::harmonic_kinematics(26, 120, 35, 40, -20);
  body.stroke_plane_on_body = true;
  const Kinematics horizontal = testing::harmonic_kinematics(26, 120, 35, 40, 20);  // -20 + 40
  const Configuration cb(ins, body), ch(ins, horizontal);
  for (double t : {0.0, 0.01, 0.023})
    for (Side s : {Side::right, Side::left}) {
      const WingPose a = cb.wing_pose(s, t), b = ch.wing_pose(s, t);
      EXPECT_LT((a.axes - b.axes).norm(), 1e-15);
      EXPECT_LT((a.hinge - b.hinge).norm(), 1e-15);
      EXPECT_LT((a.omega - b.omega).norm(), 1e-12 * a.omega.norm());
    }
  Kinematics pitched = body;
  pitched.body_angle += 15 * deg;
  const Configuration cp(ins, pitched);
  for (double t : {0.0, 0.01, 0.023})
    for (Side s : {Side::right, Side::left}) {
      const WingPose a = cb.wing_pose(s, t), b = cp.wing_pose(s, t);
      const Mat3 ra = cb.anatomical_to_stability().transpose(), rb = cp.anatomical_to_stability().transpose();
      EXPECT_LT((ra * a.axes - rb * b.axes).norm(), 1e-15);
      EXPECT_LT((ra * (a.hinge - cb.body_centre()) - rb * (b.hinge - cp.body_centre())).norm(), 1e-15);
      EXPECT_LT((ra * a.omega - rb * b.omega).norm(), 1e-12 * a.omega.norm());
    }
}

}  // namespace
}  // namespace flapstab
