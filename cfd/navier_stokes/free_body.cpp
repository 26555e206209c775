// A free rigid body carrying immersed parts through a fixed grid (free_body.hpp).
#include "cfd/navier_stokes/free_body.hpp"

#include "core/rotation.hpp"

namespace flapstab::ns {

BodyFrame body_frame(const BodyStateVector& x, const BodyStateVector& dx) {
  BodyFrame b;
  b.rotation = euler321(x(9), x(10), x(11));
  b.origin = x.segment<3>(0);
  b.velocity = x.segment<3>(3);
  b.rate = x.segment<3>(6);
  b.velocity_rate = dx.segment<3>(3);
  b.rate_rate = dx.segment<3>(6);
  return b;
}

PartState part_in_grid(const BodyFrame& b, const PartState& rel) {
  const Mat3& R = b.rotation;
  const Vec3 &w = b.rate, &c = rel.velocity.centre, &cdot = rel.velocity.velocity, &wr = rel.velocity.omega;
  PartState s;
  s.pose = RigidTransform{R, b.origin} * rel.pose;
  s.velocity.centre = R * c + b.origin;
  s.velocity.velocity = R * (b.velocity + w.cross(c) + cdot);
  s.velocity.omega = R * (w + wr);
  s.acceleration = R * (b.velocity_rate + w.cross(b.velocity) + b.rate_rate.cross(c) + w.cross(w.cross(c)) +
                        2 * w.cross(cdot) + rel.acceleration);
  s.angular_acceleration = R * (b.rate_rate + rel.angular_acceleration + w.cross(wr));
  s.frame_rate = Vec3::Zero();
  return s;
}

Wrench wrench_on_body(const BodyFrame& b, const Vec3& force_grid, const Vec3& moment_grid_origin) {
  Wrench w;
  const Mat3 Rt = b.rotation.transpose();
  w.force = Rt * force_grid;
  w.moment = Rt * (moment_grid_origin - b.origin.cross(force_grid));
  return w;
}

BodyStateVector integrate_body(const BodyRhs& rhs, double t0, const BodyStateVector& x0, double t, int substeps) {
  return runge_kutta(rhs, t0, x0, t, substeps);
}

}  // namespace flapstab::ns
