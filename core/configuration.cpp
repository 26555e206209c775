// Frames, wing poses and mass state of the insect at time t.
#include "core/configuration.hpp"
#include "core/rotation.hpp"
#include <stdexcept>

namespace flapstab {

namespace {
// Orientation, angular velocity and angular acceleration of R = Rz(-phi) Rx(-theta) Ry(alpha)
// relative to its parent frame: omega = e_z(-phi') + R1 e_x(-theta') + R1 R2 e_y alpha'.
void right_wing_rotation(const WingAngleState& a, Mat3& R, Vec3& w, Vec3& wd) {
  const Mat3 R1 = rot_z(-a.phi), R2 = rot_x(-a.theta), R3 = rot_y(a.alpha);
  const Vec3 e1 = Vec3::UnitZ(), e2 = R1 * Vec3::UnitX(), e3 = R1 * R2 * Vec3::UnitY();
  const double d1 = -a.dphi, d2 = -a.dtheta, d3 = a.dalpha;
  const double dd1 = -a.ddphi, dd2 = -a.ddtheta, dd3 = a.ddalpha;
  R = R1 * R2 * R3;
  const Vec3 w1 = e1 * d1, w12 = w1 + e2 * d2;
  w = w12 + e3 * d3;
  wd = e1 * dd1 + w1.cross(e2) * d2 + e2 * dd2 + w12.cross(e3) * d3 + e3 * dd3;
}
}  // namespace

Configuration::Configuration(const Insect& insect, const Kinematics& kin)
    : insect_(insect), kin_(kin), r_sa_(rot_y(kin.body_angle)), r_sp_(rot_y(kin.stroke_plane_in_stability())) {
  if (insect.hind_wing.has_value() != kin.has_hind)
    throw std::invalid_argument(insect.hind_wing ? "a four-winged insect needs kinematics for its hind pair"
                                                 : "hind-pair kinematics for an insect without a hind pair");
  // O = cycle-mean CoM of body + wings, measured from the body CoM (trapezoid rule: spectral for periodic data).
  constexpr int n = 256;
  Vec3 sum = Vec3::Zero();
  for (int i = 0; i < n; ++i) {
    const double t = kin.period() * i / n;
    sum += insect.wing.mass * (wing_cg_about_body_cg(Side::right, t, Pair::fore) +
                               wing_cg_about_body_cg(Side::left, t, Pair::fore));
    if (insect.hind_wing)
      sum += insect.hind_wing->mass * (wing_cg_about_body_cg(Side::right, t, Pair::hind) +
                                       wing_cg_about_body_cg(Side::left, t, Pair::hind));
    if (insect.abdomen) sum += insect.abdomen->mass * abdomen_cg_about_body_cg(t);
  }
  o_ = sum / n / insect.total_mass();
}

Configuration::Configuration(const Insect& insect, const Kinematics& kin, const Vec3& reference_point)
    : insect_(insect), kin_(kin), r_sa_(rot_y(kin.body_angle)), r_sp_(rot_y(kin.stroke_plane_in_stability())), o_(reference_point) {
  if (insect.hind_wing.has_value() != kin.has_hind)
    throw std::invalid_argument(insect.hind_wing ? "a four-winged insect needs kinematics for its hind pair"
                                                 : "hind-pair kinematics for an insect without a hind pair");
}

Vec3 Configuration::wing_cg_about_body_cg(Side s, double t, Pair pair) const {
  Mat3 R;
  Vec3 w, wd;
  right_wing_rotation(kin_.angles(s, t, pair), R, w, wd);
  const Wing& wing = insect_.pair_wing(pair);
  const Vec3 local = r_sa_ * wing.hinge + r_sp_ * R * wing.mass_centre;
  return s == Side::right ? local : Vec3(mirror_y() * local);
}

Vec3 Configuration::abdomen_cg_about_body_cg(double t, Mat3* axes, double* rate, double* acc) const {
  const Abdomen& a = *insect_.abdomen;
  const double n = kin_.frequency_hz;
  const SeriesValue eta = a.pitch.eval(t * n);
  const Mat3 R = r_sa_ * rot_y(eta.f + kin_.abdomen_flexion);
  if (axes) *axes = R;
  if (rate) *rate = eta.df * n;
  if (acc) *acc = eta.ddf * n * n;
  return r_sa_ * a.joint + R * a.centre;
}

WingPose Configuration::wing_pose(Side s, double t, Pair pair) const {
  WingPose p;
  p.side = s;
  p.angles = kin_.angles(s, t, pair);
  Mat3 R;
  Vec3 w, wd;
  right_wing_rotation(p.angles, R, w, wd);
  const Vec3 hinge = r_sa_ * insect_.pair_wing(pair).hinge;
  p.axes = r_sp_ * R;
  p.omega = r_sp_ * w;
  p.omega_dot = r_sp_ * wd;
  p.hinge = hinge;
  if (s == Side::left) {
    const Mat3 M = mirror_y();
    p.axes = M * p.axes;
    p.hinge = M * hinge;
    p.omega = -(M * p.omega);
    p.omega_dot = -(M * p.omega_dot);
  }
  p.hinge -= o_;
  return p;
}

MassState Configuration::mass_state(double t) const {
  MassState m;
  m.body.mass = insect_.body.mass;
  m.body.r = -o_;
  m.body.inertia = r_sa_ * insect_.body.inertia * r_sa_.transpose();
  for (Pair pair : {Pair::fore, Pair::hind}) {
    if (pair == Pair::hind && !insect_.hind_wing) break;
    const Wing& wing = insect_.pair_wing(pair);
    for (Side s : {Side::right, Side::left}) {
      const WingPose p = wing_pose(s, t, pair);
      PartMass& w = pair == Pair::fore ? (s == Side::right ? m.right : m.left)
                                       : (s == Side::right ? m.hind_right : m.hind_left);
      const Vec3& xi = wing.mass_centre;
      w.mass = wing.mass;
      w.r = p.position(xi);
      w.r_dot = p.velocity(xi);
      w.r_ddot = p.acceleration(xi);
      // The left wing's axes are improper, but A I A^T of a symmetric tensor is still its mirror image.
      w.inertia = p.axes * wing.inertia_cg * p.axes.transpose();
      w.omega = p.omega;
      w.omega_dot = p.omega_dot;
    }
  }
  if (insect_.abdomen) {
    // Rotation about the y axis shared by A and S: the relative angular velocity is (0, eta', 0) in both.
    const Abdomen& ab = *insect_.abdomen;
    Mat3 R;
    double rate = 0, acc = 0;
    m.abdomen.mass = ab.mass;
    m.abdomen.r = abdomen_cg_about_body_cg(t, &R, &rate, &acc) - o_;
    m.abdomen.omega = Vec3(0, rate, 0);
    m.abdomen.omega_dot = Vec3(0, acc, 0);
    const Vec3 d = R * ab.centre;  // joint to CoM
    m.abdomen.r_dot = m.abdomen.omega.cross(d);
    m.abdomen.r_ddot = m.abdomen.omega_dot.cross(d) + m.abdomen.omega.cross(m.abdomen.omega.cross(d));
    m.abdomen.inertia = R * ab.inertia_cg * R.transpose();
  }
  return m;
}

}  // namespace flapstab
