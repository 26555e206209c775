// Exact Navier-Stokes solutions used to validate and benchmark the solver (Taylor & Green 1937, Proc R Soc A 158:499; Stokes' second problem, e.g. Schlichting, Boundary-Layer Theory).
#pragma once
#include <cmath>
#include "core/types.hpp"

namespace flapstab::ns::exact {

// Taylor-Green vortex, 2D, periodic in [0, 2 pi]^2 (and any z): u = -cos x sin y e^{-2 nu t},
// v = sin x cos y e^{-2 nu t}, w = 0, p = -(cos 2x + cos 2y) e^{-4 nu t} / 4 (density 1).
inline Vec3 taylor_green_velocity(double x, double y, double t, double nu) {
  const double f = std::exp(-2 * nu * t);
  return {-std::cos(x) * std::sin(y) * f, std::sin(x) * std::cos(y) * f, 0.0};
}
inline double taylor_green_pressure(double x, double y, double t, double nu) {
  return -0.25 * (std::cos(2 * x) + std::cos(2 * y)) * std::exp(-4 * nu * t);
}

// Stokes' second problem: a wall at y = 0 oscillating in its plane with U0 cos(omega t) under fluid at rest far
// away: u = U0 e^{-y/delta} cos(omega t - y/delta), delta = sqrt(2 nu / omega) (the periodic state).
inline double stokes_second(double y, double t, double U0, double omega, double nu) {
  const double delta = std::sqrt(2 * nu / omega);
  return U0 * std::exp(-y / delta) * std::cos(omega * t - y / delta);
}

}  // namespace flapstab::ns::exact
