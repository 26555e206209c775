// Where every part of the insect is, and how it moves, at time t: frames, wing poses, mass state.
//
// Stability frame S (the frame of every wrench and derivative): body-fixed, origin at the reference
// point O = the wingbeat-mean centre of mass of the whole insect, x forward and horizontal at trim,
// y right, z down. The anatomical frame A is S pitched nose-up by the body angle chi; each wing's
// stroke-plane frame P is S pitched nose-up by the stroke-plane angle beta (by chi + beta when the stroke plane is
// fixed to the body, Kinematics::stroke_plane_on_body).
// The abdomen (Insect::abdomen) is A turned by its relative pitch eta(t) about the joint's y axis.
// Right wing orientation (wing frame -> P): Rz(-phi) Rx(-theta) Ry(alpha); the left wing is the
// mirror image in the x-z plane (positions and velocities map by M = diag(1,-1,1), angular
// velocities by -M).
#pragma once
#include <array>
#include "core/insect.hpp"
#include "core/kinematics.hpp"

namespace flapstab {

// One wing at one instant, in S (origin O).
struct WingPose {
  Side side = Side::right;
  Vec3 hinge = Vec3::Zero();    // hinge position (m)
  Mat3 axes = Mat3::Identity(); // columns: chord (to LE), span (to tip), normal; maps wing coords to S
  Vec3 omega = Vec3::Zero();    // angular velocity relative to the body (rad/s)
  Vec3 omega_dot = Vec3::Zero();// its time derivative in S (rad/s^2)
  WingAngleState angles;
  // Position, velocity and acceleration relative to the body frame of a point with wing coords xi.
  Vec3 position(const Vec3& xi) const { return hinge + axes * xi; }
  Vec3 velocity(const Vec3& xi) const { return omega.cross(axes * xi); }
  Vec3 acceleration(const Vec3& xi) const {
    const Vec3 d = axes * xi;
    return omega_dot.cross(d) + omega.cross(omega.cross(d));
  }
};

// One rigid part's mass state relative to the body frame, in S.
struct PartMass {
  double mass = 0;
  Vec3 r = Vec3::Zero(), r_dot = Vec3::Zero(), r_ddot = Vec3::Zero();  // CoM position, velocity, accel
  Mat3 inertia = Mat3::Zero();            // about its own CoM, S axes
  Vec3 omega = Vec3::Zero(), omega_dot = Vec3::Zero();  // angular velocity and accel relative to body
};

struct MassState {
  PartMass body, right, left;
  PartMass hind_right, hind_left;  // the hind pair (mass 0 for a two-winged insect)
  PartMass abdomen;                // the abdomen (mass 0 without one)
  // Every part, for sums over the system.
  std::array<const PartMass*, 6> parts() const {
    return {&body, &right, &left, &hind_right, &hind_left, &abdomen};
  }
  double total_mass() const {
    double m = 0;
    for (const PartMass* p : parts()) m += p->mass;
    return m;
  }
  Vec3 first_moment() const {
    Vec3 c = Vec3::Zero();
    for (const PartMass* p : parts()) c += p->mass * p->r;
    return c;
  }
};

class Configuration {
 public:
  Configuration(const Insect& insect, const Kinematics& kin);
  // With the reference point O given (body-CoM-origin frame, S axes, m) instead of the cycle-mean CoM of
  // these kinematics: free flight keeps O fixed in the body while a controller changes the kinematics.
  Configuration(const Insect& insect, const Kinematics& kin, const Vec3& reference_point);
  const Insect& insect() const { return insect_; }
  const Kinematics& kinematics() const { return kin_; }
  // Reference point O in the body-CoM-origin frame with S axes (m).
  const Vec3& reference_point() const { return o_; }
  // Body CoM in S.
  Vec3 body_centre() const { return -o_; }
  WingPose wing_pose(Side s, double t, Pair p = Pair::fore) const;
  MassState mass_state(double t) const;
  // Map from A to S axes.
  const Mat3& anatomical_to_stability() const { return r_sa_; }
  // The abdomen's CoM from the body CoM (S axes), its orientation (abdomen frame -> S) and the relative pitch's
  // rate and acceleration (rad/s, rad/s^2) at time t. Needs an [abdomen].
  Vec3 abdomen_cg_about_body_cg(double t, Mat3* axes = nullptr, double* rate = nullptr, double* acc = nullptr) const;

 private:
  Vec3 wing_cg_about_body_cg(Side s, double t, Pair p) const;
  const Insect& insect_;
  const Kinematics& kin_;
  Mat3 r_sa_, r_sp_;
  Vec3 o_ = Vec3::Zero();
};

}  // namespace flapstab
