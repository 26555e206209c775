// The insect's prescribed motion in the CFD grid (insect_motion.hpp).
#include "cfd/navier_stokes/insect_motion.hpp"

namespace flapstab::ns {

std::vector<PartState> InsectMotion::parts(double t) const {
  std::vector<PartState> out(std::size_t(insect_part_count(config_->insect())));
  {
    PartState& s = out[0];  // the body: at rest in its own frame
    s.pose = RigidTransform{config_->anatomical_to_stability(), config_->body_centre()};
    s.velocity.centre = s.pose.translation;
    s.frame_rate = motion_.rate;
  }
  // The wings in the order of InsectSurfaces: fore right, fore left, then the hind pair's right and left.
  std::size_t i = 1;
  for (Pair pair : {Pair::fore, Pair::hind}) {
    if (pair == Pair::hind && !config_->insect().hind_wing) break;
    for (Side side : {Side::right, Side::left}) {
      const WingPose w = config_->wing_pose(side, t, pair);
      PartState& s = out[i++];
      s.pose = wing_transform(w);
      s.velocity = wing_velocity(w);  // about the hinge, which is fixed in the body
      s.angular_acceleration = w.omega_dot;
      s.frame_rate = motion_.rate;
    }
  }
  return out;
}

}  // namespace flapstab::ns
