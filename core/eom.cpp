// Rigid body + two prescribed-motion wings: Newton-Euler equations about the reference point O.
#include "core/eom.hpp"
#include <cmath>
#include <unsupported/Eigen/AutoDiff>
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
  for (const PartMass* p : ms.parts()) {
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
                                      const Wrench& aero, std::optional<double> g) {
  const MassState ms = config.mass_state(t);
  const EomTerms e = eom_terms(ms, x, aero, g.value_or(config.insect().gravity));
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

Eigen::Matrix<double, 12, 12> body_state_jacobian(const Configuration& config, double t, const BodyStateVector& x,
                                                  const Eigen::Matrix<double, 6, 6>& aero_jacobian,
                                                  std::optional<double> g_given) {
  const double g = g_given.value_or(config.insect().gravity);
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 12, 1>>;
  using V = Eigen::Matrix<AD, 3, 1>;
  using M3 = Eigen::Matrix<AD, 3, 3>;
  const Aggregates a = aggregate(config.mass_state(t));
  Eigen::Matrix<AD, 12, 1> X;
  for (int i = 0; i < 12; ++i) X(i) = AD(x(i), 12, i);
  const V v = X.segment<3>(3), w = X.segment<3>(6);
  const AD &phi = X(9), &theta = X(10), &psi = X(11);
  using std::cos;
  using std::sin;
  using std::tan;
  const AD sp = sin(phi), cp = cos(phi), st = sin(theta), ct = cos(theta), ss = sin(psi), cs = cos(psi);
  M3 R;  // euler321: Rz(psi) Ry(theta) Rx(phi)
  R << ct * cs, sp * st * cs - cp * ss, cp * st * cs + sp * ss, ct * ss, sp * st * ss + cp * cs,
      cp * st * ss - sp * cs, -st, sp * ct, cp * ct;
  const V g_body = V(-st, sp * ct, cp * ct) * g;
  V fa, ma;  // the wrench's response (value zero: it does not enter the derivative)
  for (int i = 0; i < 3; ++i) {
    Eigen::Matrix<double, 12, 1> df = Eigen::Matrix<double, 12, 1>::Zero(), dm = df;
    df.segment<6>(3) = aero_jacobian.row(i).transpose();
    dm.segment<6>(3) = aero_jacobian.row(3 + i).transpose();
    fa(i) = AD(0.0, df);
    ma(i) = AD(0.0, dm);
  }
  const V c = a.c.cast<AD>(), c_dot = a.c_dot.cast<AD>(), h_rel = a.h_rel.cast<AD>();
  const V P = a.m * v + w.cross(c) + c_dot;
  const V H = c.cross(v) + a.J.cast<AD>() * w + h_rel;
  const V F = fa + a.m * g_body;
  const V Mo = ma + c.cross(g_body);
  const V rhs_f = F - w.cross(P) - w.cross(c_dot);
  const V rhs_m = Mo - w.cross(H) - v.cross(P) - c_dot.cross(v) - a.J_dot.cast<AD>() * w;
  Eigen::Matrix<double, 6, 6> mass;
  mass << a.m * Mat3::Identity(), -skew(a.c), skew(a.c), a.J;
  Eigen::Matrix<double, 6, 12> d_rhs;
  for (int i = 0; i < 3; ++i) {
    d_rhs.row(i) = rhs_f(i).derivatives().transpose();
    d_rhs.row(3 + i) = rhs_m(i).derivatives().transpose();
  }
  Eigen::Matrix<double, 12, 12> J;
  const V pos_dot = R * v;
  const AD phi_dot = w(0) + (w(1) * sp + w(2) * cp) * tan(theta), theta_dot = w(1) * cp - w(2) * sp,
           psi_dot = (w(1) * sp + w(2) * cp) / ct;
  for (int i = 0; i < 3; ++i) J.row(i) = pos_dot(i).derivatives().transpose();
  J.middleRows<6>(3) = mass.partialPivLu().solve(d_rhs);
  J.row(9) = phi_dot.derivatives().transpose();
  J.row(10) = theta_dot.derivatives().transpose();
  J.row(11) = psi_dot.derivatives().transpose();
  return J;
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
