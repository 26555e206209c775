// Basic value types, constants and conventions shared by every flapstab layer.
#pragma once
#include <Eigen/Dense>
#include <numbers>

namespace flapstab {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr double pi = std::numbers::pi;
constexpr double deg = pi / 180.0;      // multiply degrees by this to get radians
constexpr double standard_gravity = 9.80665;  // m/s^2

enum class Side { right, left };
// The wing pair: the fore pair (every insect) and an optional hind pair (four-winged insects: dragonflies, flapping
// MAVs; docs/case-file.md [hind_wing]).
enum class Pair { fore, hind };

// Force and moment (about the reference point O, in stability axes), SI units.
struct Wrench {
  Vec3 force = Vec3::Zero();   // N
  Vec3 moment = Vec3::Zero();  // N m
  Wrench& operator+=(const Wrench& o) { force += o.force; moment += o.moment; return *this; }
  friend Wrench operator+(Wrench a, const Wrench& b) { return a += b; }
  friend Wrench operator*(double s, Wrench a) { a.force *= s; a.moment *= s; return a; }
};

}  // namespace flapstab
