// Rotation matrices (active, right-handed), skew matrices.
#include "core/rotation.hpp"
#include <cmath>

namespace flapstab {

Mat3 rot_x(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 m;
  m << 1, 0, 0, 0, c, -s, 0, s, c;
  return m;
}
Mat3 rot_y(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 m;
  m << c, 0, s, 0, 1, 0, -s, 0, c;
  return m;
}
Mat3 rot_z(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Mat3 m;
  m << c, -s, 0, s, c, 0, 0, 0, 1;
  return m;
}
Mat3 euler321(double phi, double theta, double psi) { return rot_z(psi) * rot_y(theta) * rot_x(phi); }
Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace flapstab
