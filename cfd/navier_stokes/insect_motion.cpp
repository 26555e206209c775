// The insect's prescribed motion in the CFD grid (insect_motion.hpp).
#include "cfd/navier_stokes/insect_motion.hpp"

namespace flapstab::ns {

std::vector<PartState> InsectMotion::parts(double t) const {
  std::vector<PartState> out(3);
  {
    PartState& s = out[0];  // the body: at rest in its own frame
    s.pose = RigidTransform{config_->anatomical_to_stability(), config_->body_centre()};
    s.velocity.centre = s.pose.translation;
    s.frame_rate = motion_.rate;
  }
  for (Side side : {Side::right, Side::left}) {
    const WingPose w = config_->wing_pose(side, t);
    PartState& s = out[side == Side::right ? 1 : 2];
    s.pose = wing_transform(w);
    s.velocity = wing_velocity(w);  // about the hinge, which is fixed in the body
    s.angular_acceleration = w.omega_dot;
    s.frame_rate = motion_.rate;
  }
  return out;
}

}  // namespace flapstab::ns
