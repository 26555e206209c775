// The free body's state with names: position and attitude in the inertial frame, velocity and rates in body axes.
//
// Inertial frame x forward, y right, z down (gravity +z); body axes = hover stability axes S (x forward and
// horizontal at trim, z down), origin at the reference point O. Attitude: 3-2-1 Euler angles (yaw psi, pitch
// theta, roll phi). The integrators work on BodyStateVector = [x y z | u v w | p q r | phi theta psi]; this is
// the one place that order is written down.
#pragma once
#include <optional>
#include <string>
#include <vector>
#include "core/eom.hpp"

namespace flapstab {

struct BodyState {
  Vec3 position = Vec3::Zero();  // of O, inertial axes (m)
  Vec3 velocity = Vec3::Zero();  // of O, body axes (m/s): u, v, w
  Vec3 rates = Vec3::Zero();     // body axes (rad/s): p, q, r
  double roll = 0, pitch = 0, yaw = 0;  // phi, theta, psi (rad)

  BodyStateVector to_vector() const {
    BodyStateVector x;
    x << position, velocity, rates, roll, pitch, yaw;
    return x;
  }
  static BodyState from_vector(const BodyStateVector& x) {
    BodyState s;
    s.position = x.segment<3>(0);
    s.velocity = x.segment<3>(3);
    s.rates = x.segment<3>(6);
    s.roll = x(9);
    s.pitch = x(10);
    s.yaw = x(11);
    return s;
  }
};

// {"x","y","z","u","v","w","p","q","r","phi","theta","psi"}: the names of BodyStateVector's entries.
inline const std::vector<std::string>& body_state_names() {
  static const std::vector<std::string> names{"x", "y", "z", "u", "v", "w", "p", "q", "r", "phi", "theta", "psi"};
  return names;
}
// SI unit of each entry of BodyStateVector.
inline const std::vector<std::string>& body_state_units() {
  static const std::vector<std::string> units{"m", "m", "m", "m/s", "m/s", "m/s", "rad/s", "rad/s", "rad/s",
                                              "rad", "rad", "rad"};
  return units;
}
// Index of a named state in BodyStateVector, or nothing for an unknown name.
inline std::optional<int> body_state_index(const std::string& name) {
  const auto& n = body_state_names();
  for (std::size_t i = 0; i < n.size(); ++i)
    if (n[i] == name) return int(i);
  return std::nullopt;
}

}  // namespace flapstab
