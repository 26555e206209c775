// Rotation matrices (active, right-handed), skew matrices and the left/right mirror.
#pragma once
#include "core/types.hpp"

namespace flapstab {

// Active rotation by angle a (rad) about the x, y or z axis: v' = R v.
Mat3 rot_x(double a);
Mat3 rot_y(double a);
Mat3 rot_z(double a);
// Body-to-inertial matrix for 3-2-1 Euler angles (yaw psi, pitch theta, roll phi):
// R = Rz(psi) Ry(theta) Rx(phi); v_inertial = R v_body.
Mat3 euler321(double phi, double theta, double psi);
// [v]x such that skew(v) w = v x w.
Mat3 skew(const Vec3& v);
// Mirror in the body's plane of symmetry (x-z): y -> -y.
inline Mat3 mirror_y() { return Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal(); }

}  // namespace flapstab
