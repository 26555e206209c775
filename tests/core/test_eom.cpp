// Tests for core/eom: momentum conservation with flapping wings and no external load, free fall,
// and reduction to Euler's rigid-body equations for massless wings.
#include <gtest/gtest.h>
#include "common/test_insect.hpp"
#include "core/eom.hpp"
#include "core/rotation.hpp"

namespace flapstab {
namespace {

BodyStateVector rk4(const Configuration& cfg, BodyStateVector x, double t0, double t1, int steps, double g) {
  const double h = (t1 - t0) / steps;
  const Wrench none;
  for (int i = 0; i < steps; ++i) {
    const double t = t0 + i * h;
    const auto k1 = body_state_derivative(cfg, t, x, none, g);
    const auto k2 = body_state_derivative(cfg, t + h / 2, x + h / 2 * k1, none, g);
    const auto k3 = body_state_derivative(cfg, t + h / 2, x + h / 2 * k2, none, g);
    const auto k4 = body_state_derivative(cfg, t + h, x + h * k3, none, g);
    x += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return x;
}

// The start of the tests below: translating, spinning and tilted, so that every inertial term acts.
BodyStateVector moving_state() {
  BodyStateVector x = BodyStateVector::Zero();
  x.segment<3>(3) = Vec3(0.1, -0.05, 0.02);
  x.segment<3>(6) = Vec3(1.0, -2.0, 0.5);
  x.segment<3>(9) = Vec3(0.1, 0.2, -0.3);
  return x;
}

// Two configurations that must be the same mechanical system: the equations of motion agree at a moving state under
// a general wrench, at three instants of the wingbeat, to round-off (1e-12 relative).
void expect_same_equations_of_motion(const Configuration& a, const Configuration& b) {
  const BodyStateVector x = moving_state();
  Wrench w;
  w.force = Vec3(1e-3, 2e-4, -1.5e-2);
  w.moment = Vec3(1e-5, -3e-5, 2e-6);
  for (double t : {0.0, 0.011, 0.027}) {
    const BodyStateVector da = body_state_derivative(a, t, x, w), db = body_state_derivative(b, t, x, w);
    EXPECT_LT((da - db).norm(), 1e-12 * db.norm()) << t;
  }
}

// Two wingbeats from moving_state() without gravity or loads (RK4, 4000 steps per cycle): the change of the system's
// linear and angular momentum (inertial axes) and the end state.
struct MomentumChange {
  Vec3 dP, dH;
  BodyStateVector x0, x1;
};
MomentumChange momentum_change(const Configuration& cfg) {
  MomentumChange m;
  const double T = cfg.kinematics().period();
  m.x0 = moving_state();
  Vec3 P0, H0, P1, H1;
  system_momenta(cfg, 0.0, m.x0, P0, H0);
  m.x1 = rk4(cfg, m.x0, 0.0, 2 * T, 8000, 0.0);
  system_momenta(cfg, 2 * T, m.x1, P1, H1);
  m.dP = P1 - P0;
  m.dH = H1 - H0;
  return m;
}

// Without gravity and aerodynamics, the wings' flapping moves the body but the total linear and
// angular momentum stay constant (Newton's laws for the closed system). Asymmetric kinematics and a
// tilted, spinning initial state exercise every inertial term. RK4 error at 4000 steps/cycle ~1e-12.
TEST(Eom, FlappingConservesMomentumWithoutExternalLoads) {
  Insect ins = testing::test_insect();
  ins.wing.mass *= 3;  // heavier wings: larger inertial coupling
  Kinematics k = testing::harmonic_kinematics(26, 120, 35, 40, 10);
  k.left = testing::harmonic_wing(100, 30, 10, 5);
  const MomentumChange m = momentum_change(Configuration(ins, k));
  const double p_scale = ins.wing.mass * 2 * pi * 26 * ins.wing.length;  // wing momentum scale
  EXPECT_LT(m.dP.norm(), 1e-9 * p_scale);
  EXPECT_LT(m.dH.norm(), 1e-9 * p_scale * ins.wing.length);
  // The body did move (the test is not vacuous).
  EXPECT_GT((m.x1.segment<3>(6) - m.x0.segment<3>(6)).norm(), 1e-3);
}

TEST(Eom, FreeFallAcceleratesAtG) {
  const Insect ins = testing::test_insect();
  Kinematics k = testing::harmonic_kinematics(26, 0.0, 35);
  k.right.stroke = FourierSeries{0.0, {}, {}};
  k.right.pitch = FourierSeries{0.5, {}, {}};
  k.left = k.right;
  const Configuration cfg(ins, k);
  BodyStateVector x = BodyStateVector::Zero();
  x(10) = 0.3;  // pitched: gravity has body-axis components
  const auto dx = body_state_derivative(cfg, 0.0, x, Wrench{}, 9.81);
  const Vec3 a_inertial = euler321(0, 0.3, 0) * dx.segment<3>(3);
  EXPECT_NEAR(a_inertial.z(), 9.81, 1e-12);
  EXPECT_NEAR(a_inertial.x(), 0.0, 1e-12);
  EXPECT_NEAR(dx.segment<3>(6).norm(), 0.0, 1e-12);
  // Without an explicit g the equations take the insect's ([environment] gravity_m_s2): Mars, 3.71 m/s^2.
  Insect mars = ins;
  mars.gravity = 3.71;
  const Configuration cfg_mars(mars, k);
  const Vec3 a_mars = euler321(0, 0.3, 0) * body_state_derivative(cfg_mars, 0.0, x, Wrench{}).segment<3>(3);
  EXPECT_NEAR(a_mars.z(), 3.71, 1e-12);
  EXPECT_NEAR(a_mars.x(), 0.0, 1e-12);
}

TEST(Eom, MasslessWingsGiveEulerRigidBodyEquations) {
  Insect ins = testing::test_insect();
  ins.wing.mass = 0;
  ins.wing.inertia_cg.setZero();
  ins.body.inertia = Eigen::Vector3d(1e-9, 3e-9, 2.5e-9).asDiagonal();
  const Kinematics k = testing::harmonic_kinematics();
  const Configuration cfg(ins, k);
  BodyStateVector x = BodyStateVector::Zero();
  x.segment<3>(6) = Vec3(3, -1, 2);
  Wrench aero;
  aero.moment = Vec3(1e-8, 2e-8, -1e-8);
  const auto dx = body_state_derivative(cfg, 0.01, x, aero, 0.0);
  const Mat3 I = cfg.anatomical_to_stability() * ins.body.inertia * cfg.anatomical_to_stability().transpose();
  const Vec3 w = x.segment<3>(6);
  const Vec3 expected = I.inverse() * (aero.moment - w.cross(I * w));
  EXPECT_LT((dx.segment<3>(6) - expected).norm(), 1e-10 * expected.norm());
}

}  // namespace
}  // namespace flapstab

namespace flapstab {
namespace {

// Four wings: a hind pair with its own planform, hinge, mass and kinematics (phase-shifted) in the mass properties
// and the inertial terms. Without loads the total momentum of body + four wings is conserved (RK4 at 4000 steps per
// cycle, 1e-9 of the wing momentum scale, as for two wings).
TEST(Eom, FourWingsConserveMomentumWithoutExternalLoads) {
  Insect ins = testing::test_insect();
  Wing hind = ins.wing;
  hind.planform = Planform::rectangular;
  hind.length *= 0.9;
  hind.mass *= 2;
  hind.hinge = Vec3(-0.008, 0.005, -0.002);
  Vec3 c;
  Mat3 ih;
  hind.plate_mass_properties(c, ih);
  hind.mass_centre = c;
  hind.inertia_cg = ih - hind.mass * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  ins.hind_wing = hind;
  Kinematics k = testing::harmonic_kinematics(26, 120, 35, 40, 10);
  k.has_hind = true;
  k.hind_right = testing::harmonic_wing(100, 30, 10, 5);
  k.hind_left = testing::harmonic_wing(90, 40, -5, 3);
  k.hind_phase = 0.3;
  const Configuration cfg(ins, k);
  const MomentumChange m = momentum_change(cfg);
  const double p_scale = hind.mass * 2 * pi * 26 * ins.wing.length;
  EXPECT_LT(m.dP.norm(), 1e-9 * p_scale);
  EXPECT_LT(m.dH.norm(), 1e-9 * p_scale * ins.wing.length);
  EXPECT_GT((m.x1.segment<3>(6) - m.x0.segment<3>(6)).norm(), 1e-3);
  EXPECT_NEAR(cfg.mass_state(0.1).total_mass(), ins.total_mass(), 1e-18);
}

// A hind pair identical to the fore pair and in phase with it is the two-winged insect with doubled wing masses and
// inertias: the same equations of motion, to round-off (1e-12 relative).
TEST(Eom, IdenticalInPhaseHindPairDoublesTheWingMass) {
  Insect four = testing::test_insect(), two = four;
  four.hind_wing = four.wing;
  two.wing.mass *= 2;
  two.wing.inertia_cg *= 2;
  Kinematics k4 = testing::harmonic_kinematics(26, 120, 35, 40, 10), k2 = k4;
  k4.has_hind = true;
  k4.hind_right = k4.right;
  k4.hind_left = k4.left;
  const Configuration c4(four, k4), c2(two, k2);
  EXPECT_LT((c4.reference_point() - c2.reference_point()).norm(), 1e-15);
  expect_same_equations_of_motion(c4, c2);
}

}  // namespace
}  // namespace flapstab

namespace flapstab {
namespace {

// An abdomen of about half the body mass, hinged aft of the thorax, with its CoM below its long axis and a product
// of inertia: every term of a part turning about the joint.
Abdomen test_abdomen() {
  Abdomen a;
  a.mass = 0.8e-3;
  a.joint = Vec3(-0.006, 0, 0.001);
  a.centre = Vec3(-0.012, 0, 0.002);
  Mat3 ij;
  ij << 1.2e-8, 0, 1.7e-8, 0, 1.6e-7, 0, 1.7e-8, 0, 1.55e-7;  // about the joint (Ixz = -1.7e-8)
  a.inertia_cg = ij - a.mass * (a.centre.squaredNorm() * Mat3::Identity() - a.centre * a.centre.transpose());
  return a;
}

// Abdomen: a second body segment whose relative pitch (two harmonics about a bent mean) is prescribed. Without loads
// the total momentum of thorax + abdomen + wings is conserved (RK4 at 4000 steps per cycle, 1e-9 of the wing
// momentum scale, as for the wings alone); the abdomen's own momentum scale is of the same order.
TEST(Eom, AbdomenConservesMomentumWithoutExternalLoads) {
  Insect ins = testing::test_insect();
  ins.abdomen = test_abdomen();
  ins.abdomen->pitch = FourierSeries{-10 * deg, {15 * deg, 3 * deg}, {5 * deg, -2 * deg}};
  Kinematics k = testing::harmonic_kinematics(26, 120, 35, 40, 10);
  k.left = testing::harmonic_wing(100, 30, 10, 5);
  const Configuration cfg(ins, k);
  EXPECT_NEAR(cfg.mass_state(0.01).total_mass(), ins.total_mass(), 1e-18);
  const MomentumChange m = momentum_change(cfg);
  const double p_scale = ins.wing.mass * 2 * pi * 26 * ins.wing.length;
  std::printf("    abdomen: |dP| = %.3g of the wing momentum scale, |dH| = %.3g\n", m.dP.norm() / p_scale,
              m.dH.norm() / (p_scale * ins.wing.length));
  EXPECT_LT(m.dP.norm(), 1e-9 * p_scale);
  EXPECT_LT(m.dH.norm(), 1e-9 * p_scale * ins.wing.length);
  EXPECT_GT((m.x1.segment<3>(6) - m.x0.segment<3>(6)).norm(), 1e-3);
  // The abdomen's motion matters: the same run with a rigid abdomen ends elsewhere.
  Insect rigid = ins;
  rigid.abdomen->pitch = FourierSeries{-10 * deg, {}, {}};
  EXPECT_GT((momentum_change(Configuration(rigid, k)).x1 - m.x1).norm(), 1e-3 * m.x1.norm());
}

// abdomen_flexion (the trim and actuator parameter abdomen_flexion_deg) adds to the relative pitch at every phase:
// a flexion of 7 deg on the oscillating abdomen equals the same series with its mean raised by 7 deg, in the
// reference point, the mass state and the equations of motion (to round-off, 1e-15 and 1e-12); and it does move
// the abdomen (the CoM shifts by m_a / m x the abdomen CoM's displacement, checked against the rotation by hand).
TEST(Eom, AbdomenFlexionShiftsTheRelativePitch) {
  Insect ins = testing::test_insect();
  ins.abdomen = test_abdomen();
  ins.abdomen->pitch = FourierSeries{-10 * deg, {15 * deg, 3 * deg}, {5 * deg, -2 * deg}};
  Insect shifted = ins;
  shifted.abdomen->pitch = FourierSeries{-3 * deg, {15 * deg, 3 * deg}, {5 * deg, -2 * deg}};
  const Kinematics k = testing::harmonic_kinematics(26, 120, 35, 40, 10);
  Kinematics kf = k;  // Configuration keeps a reference to its kinematics: one object per configuration
  kf.abdomen_flexion = 7 * deg;
  const Configuration plain(ins, k), moved(shifted, k), flexed(ins, kf);
  EXPECT_LT((flexed.reference_point() - moved.reference_point()).norm(), 1e-15);
  EXPECT_GT((flexed.reference_point() - plain.reference_point()).norm(), 1e-5);
  expect_same_equations_of_motion(flexed, moved);
  // A rigid abdomen flexed by 7 deg: its CoM turns about the joint, p = joint + R_y(7 deg) centre (A axes), so the
  // insect's CoM in A moves by m_a (p - p0) / m. R_y by hand: positive turns x towards -z (tip ventral for x < 0).
  Insect rigid = ins;
  rigid.abdomen->pitch = FourierSeries{0.0, {}, {}};
  Kinematics k0 = testing::harmonic_kinematics(26, 120, 35, 40, 10), k7 = k0;
  k7.abdomen_flexion = 7 * deg;
  const Configuration r0(rigid, k0), r7(rigid, k7);
  const Vec3 c = rigid.abdomen->centre;
  const double s = std::sin(7 * deg), co = std::cos(7 * deg);
  const Vec3 turned(co * c.x() + s * c.z(), c.y(), -s * c.x() + co * c.z());
  const Vec3 expected = r0.anatomical_to_stability() * (rigid.abdomen->mass * (turned - c) / rigid.total_mass());
  EXPECT_LT((r7.reference_point() - r0.reference_point() - expected).norm(), 1e-15);
  EXPECT_GT(expected.z(), 0);  // for this abdomen (behind the joint) the CoM moves ventrally
}

// A rigid abdomen (constant relative pitch, bent by 12 deg) is one body with the combined mass properties: mass
// m_t + m_a, CoM d = m_a p / m (p the abdomen CoM in A), inertia by the parallel-axis theorem, the hinges moved by
// -d. The reference point, the mass state's aggregates and the equations of motion agree to round-off (1e-12).
TEST(Eom, RigidAbdomenEqualsCombinedBody) {
  Insect two = testing::test_insect();
  two.abdomen = test_abdomen();
  two.abdomen->pitch = FourierSeries{12 * deg, {}, {}};
  const Abdomen& a = *two.abdomen;
  const Mat3 R = rot_y(a.pitch.eval(0).f);
  const Vec3 p = a.joint + R * a.centre;
  Insect one = two;
  one.abdomen.reset();
  one.body.mass = two.body.mass + a.mass;
  const Vec3 d = a.mass * p / one.body.mass;
  auto shift = [](double m, const Vec3& r) { return m * (r.squaredNorm() * Mat3::Identity() - r * r.transpose()); };
  one.body.inertia = two.body.inertia + shift(two.body.mass, d) + R * a.inertia_cg * R.transpose() + shift(a.mass, p - d);
  one.wing.hinge -= d;
  const Kinematics k = testing::harmonic_kinematics(26, 120, 35, 40, 10);
  const Configuration c2(two, k), c1(one, k);
  // O in S from each body's CoM: they differ by d (in S axes).
  EXPECT_LT((c2.reference_point() - c1.reference_point() - c1.anatomical_to_stability() * d).norm(), 1e-15);
  const BodyStateVector x = moving_state();
  Wrench w;
  w.force = Vec3(1e-3, 2e-4, -1.5e-2);
  w.moment = Vec3(1e-5, -3e-5, 2e-6);
  double worst = 0;
  for (double t : {0.0, 0.011, 0.027}) {
    const BodyStateVector d2 = body_state_derivative(c2, t, x, w), d1 = body_state_derivative(c1, t, x, w);
    worst = std::max(worst, (d2 - d1).norm() / d1.norm());
    Eigen::Matrix<double, 6, 6> aj = Eigen::Matrix<double, 6, 6>::Identity() * 1e-3;
    const auto j2 = body_state_jacobian(c2, t, x, aj), j1 = body_state_jacobian(c1, t, x, aj);
    worst = std::max(worst, (j2 - j1).norm() / j1.norm());
  }
  std::printf("    rigid abdomen vs combined body: largest relative difference %.3g\n", worst);
  EXPECT_LT(worst, 1e-12);
}

}  // namespace
}  // namespace flapstab
