// The insect's prescribed motion in the CFD grid (insect_motion.hpp).
#include "cfd/navier_stokes/insect_motion.hpp"

namespace flapstab::ns {

RigidTransform InsectMotion::body_rotation(double t) const {
  RigidTransform b;
  const double w = motion_.rate.norm();
  if (w > 0) b.rotation = Eigen::AngleAxisd(w * (t - t_start_), motion_.rate / w).toRotationMatrix();
  return b;
}

std::vector<PartState> InsectMotion::parts(double t) const {
  const RigidTransform b = body_rotation(t);
  const Vec3& W = motion_.rate;
  std::vector<PartState> out(3);
  // Body: fixed in the body frame.
  {
    PartState& s = out[0];
    s.pose = b * RigidTransform{config_->anatomical_to_stability(), config_->body_centre()};
    s.velocity.centre = s.pose.translation;
    s.velocity.velocity = W.cross(s.velocity.centre);
    s.velocity.omega = W;
    s.acceleration = W.cross(W.cross(s.velocity.centre));
  }
  for (Side side : {Side::right, Side::left}) {
    const WingPose w = config_->wing_pose(side, t);
    PartState& s = out[side == Side::right ? 1 : 2];
    s.pose = b * wing_transform(w);
    const Vec3 hinge = b.apply(w.hinge), omega_rel = b.rotation * w.omega;
    s.velocity.centre = hinge;
    s.velocity.velocity = W.cross(hinge);
    s.velocity.omega = W + omega_rel;
    s.acceleration = W.cross(W.cross(hinge));
    s.angular_acceleration = b.rotation * w.omega_dot + W.cross(omega_rel);
  }
  return out;
}

std::array<RigidVelocity, 3> InsectMotion::relative(double t) const {
  const RigidTransform b = body_rotation(t);
  std::array<RigidVelocity, 3> out;
  out[0].centre = b.apply(config_->body_centre());
  for (Side side : {Side::right, Side::left}) {
    const WingPose w = config_->wing_pose(side, t);
    RigidVelocity& r = out[side == Side::right ? 1 : 2];
    r.centre = b.apply(w.hinge);
    r.omega = b.rotation * w.omega;
  }
  return out;
}

}  // namespace flapstab::ns
