// Rigid body + two prescribed-motion wings: Newton-Euler equations about the reference point O.
#include "core/eom.hpp"
#include <cmath>
#include "core/rotation.hpp"

namespace flapstab {

namespace {
struct Aggregates {
  double m = 0;
  Vec3 c = Vec3::Zero(), c_dot = Vec3::Zero(), sum_m_rddot = Vec3::Zero();
  Mat3 J = Mat3::Zero(), J_dot = Mat3::Zero();
  Vec3 h_rel = Vec3::Zero(), h_rel_dot = Vec3::Zero();
};

Aggregates aggregate(const MassState& ms) {
  Aggregates a;
  const Mat3 I3 = Mat3::Identity();
  for (const PartMass* p : {&ms.body, &ms.right, &ms.left}) {
    const Vec3& r = p->r;
    const Vec3& rd = p->r_dot;
    a.m += p->mass;
    a.c += p->mass * r;
    a.c_dot += p->mass * rd;
    a.sum_m_rddot += p->mass * p->r_ddot;
    // Inertia tensor rate of a part spinning at omega relative to the body: [w]I - I[w].
    const Mat3 I_dot = skew(p->omega) * p->inertia - p->inertia * skew(p->omega);
    a.J += p->mass * (r.squaredNorm() * I3 - r * r.transpose()) + p->inertia;
    a.J_dot += p->mass * (2 * r.dot(rd) * I3 - rd * r.transpose() - r * rd.transpose()) + I_dot;
    a.h_rel += p->mass * r.cross(rd) + p->inertia * p->omega;
    a.h_rel_dot += p->mass * r.cross(p->r_ddot) + I_dot * p->omega + p->inertia * p->omega_dot;
  }
  return a;
}
}  // namespace

EomTerms eom_terms(const MassState& ms, const BodyStateVector& x, const Wrench& aero, double g) {
  const Aggregates a = aggregate(ms);
  const Vec3 v = x.segment<3>(3), w = x.segment<3>(6);
  const Mat3 R = euler321(x(9), x(10), x(11));  // body -> inertial
  const Vec3 g_body = R.transpose() * Vec3(0, 0, g);
  const Vec3 P = a.m * v + w.cross(a.c) + a.c_dot;
  const Vec3 H = a.c.cross(v) + a.J * w + a.h_rel;
  const Vec3 F = aero.force + a.m * g_body;
  const Vec3 M = aero.moment + a.c.cross(g_body);
  EomTerms t;
  t.mass_matrix << a.m * Mat3::Identity(), -skew(a.c), skew(a.c), a.J;
  t.rhs.head<3>() = F - w.cross(P) - w.cross(a.c_dot) - a.sum_m_rddot;
  t.rhs.tail<3>() = M - w.cross(H) - v.cross(P) - a.c_dot.cross(v) - a.J_dot * w - a.h_rel_dot;
  return t;
}

BodyStateVector body_state_derivative(const Configuration& config, double t, const BodyStateVector& x,
                                      const Wrench& aero, double g) {
  const MassState ms = config.mass_state(t);
  const EomTerms e = eom_terms(ms, x, aero, g);
  const Eigen::Matrix<double, 6, 1> acc = e.mass_matrix.partialPivLu().solve(e.rhs);
  const double phi = x(9), theta = x(10);
  const Vec3 w = x.segment<3>(6);
  BodyStateVector dx;
  dx.segment<3>(0) = euler321(x(9), x(10), x(11)) * x.segment<3>(3);
  dx.segment<6>(3) = acc;
  const double sp = std::sin(phi), cp = std::cos(phi), ct = std::cos(theta), tt = std::tan(theta);
  dx(9) = w.x() + (w.y() * sp + w.z() * cp) * tt;
  dx(10) = w.y() * cp - w.z() * sp;
  dx(11) = (w.y() * sp + w.z() * cp) / ct;
  return dx;
}

void system_momenta(const Configuration& config, double t, const BodyStateVector& x, Vec3& P_inertial,
                    Vec3& H_inertial) {
  const Aggregates a = aggregate(config.mass_state(t));
  const Vec3 v = x.segment<3>(3), w = x.segment<3>(6), pos = x.head<3>();
  const Mat3 R = euler321(x(9), x(10), x(11));
  const Vec3 P = a.m * v + w.cross(a.c) + a.c_dot;
  const Vec3 H_O = a.c.cross(v) + a.J * w + a.h_rel;  // about the moving point O
  P_inertial = R * P;
  // About the fixed inertial origin: H_0 = H_O + r_O x P (the c x v term already makes H_O the
  // momentum of the absolute motion about O).
  H_inertial = R * H_O + pos.cross(P_inertial);
}

}  // namespace flapstab
