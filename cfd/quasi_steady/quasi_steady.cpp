// Quasi-steady blade-element aerodynamics: per-strip translational, rotational and added-mass loads.
//
// Every formula is derived, with its source, in docs/theory/quasi-steady.md (section numbers below).
#include "cfd/quasi_steady/quasi_steady.hpp"
#include "core/quadrature.hpp"
#include "core/rotation.hpp"
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace flapstab {

namespace {

// sgn with sgn(0) = +1, so that every direction below is defined at the fold points.
double sgn(double x) { return x < 0 ? -1.0 : 1.0; }

}  // namespace

// Section 3: Robofly fits (Dickinson, Lehmann & Sane 1999; Sane & Dickinson 2001) and the
// Berman & Wang 2007 thin-plate set, alpha folded into [0, pi/2].
namespace {

// Clamped cubic spline through (x_i, y_i); end slopes from the cubic through the four end points (third-order
// one-sided differences), so that a smooth tabulated function is reproduced to O(h^4) up to the ends.
class ClampedSpline {
 public:
  ClampedSpline(const std::vector<double>& x, const std::vector<double>& y) : x_(x), y_(y), m_(x.size()) {
    const std::size_t n = x.size();
    auto end_slope = [&](std::size_t i0, int dir) {
      // Derivative at x[i0] of the Lagrange cubic (or lower order) through the nearest points.
      const std::size_t k = std::min<std::size_t>(4, n);
      std::vector<std::size_t> idx;
      for (std::size_t j = 0; j < k; ++j) idx.push_back(dir > 0 ? i0 + j : i0 - j);
      double d = 0;
      for (std::size_t a = 0; a < k; ++a) {
        double w = 0;
        for (std::size_t b = 0; b < k; ++b) {
          if (b == a) continue;
          double p = 1 / (x[idx[a]] - x[idx[b]]);
          for (std::size_t c = 0; c < k; ++c)
            if (c != a && c != b) p *= (x[i0] - x[idx[c]]) / (x[idx[a]] - x[idx[c]]);
          w += p;
        }
        d += w * y[idx[a]];
      }
      return d;
    };
    // Tridiagonal system for the knot slopes m_i (C2 continuity), with m_0 and m_{n-1} given.
    m_.front() = end_slope(0, +1);
    m_.back() = end_slope(n - 1, -1);
    if (n > 2) {
      const std::size_t k = n - 2;
      std::vector<double> a(k), b(k), c(k), r(k);
      for (std::size_t i = 1; i + 1 < n; ++i) {
        const double h0 = x[i] - x[i - 1], h1 = x[i + 1] - x[i];
        a[i - 1] = 1 / h0;
        b[i - 1] = 2 / h0 + 2 / h1;
        c[i - 1] = 1 / h1;
        r[i - 1] = 3 * ((y[i] - y[i - 1]) / (h0 * h0) + (y[i + 1] - y[i]) / (h1 * h1));
      }
      r.front() -= a.front() * m_.front();
      r.back() -= c.back() * m_.back();
      for (std::size_t i = 1; i < k; ++i) {  // Thomas algorithm (diagonally dominant)
        const double f = a[i] / b[i - 1];
        b[i] -= f * c[i - 1];
        r[i] -= f * r[i - 1];
      }
      m_[k] = r[k - 1] / b[k - 1];
      for (std::size_t i = k - 1; i-- > 0;) m_[i + 1] = (r[i] - c[i] * m_[i + 2]) / b[i];
    }
  }
  double operator()(double t) const {
    const std::size_t n = x_.size();
    std::size_t j = std::size_t(std::upper_bound(x_.begin(), x_.end(), t) - x_.begin());
    j = std::clamp<std::size_t>(j, 1, n - 1);
    const double h = x_[j] - x_[j - 1], s = (t - x_[j - 1]) / h, s2 = s * s, s3 = s2 * s;
    return (2 * s3 - 3 * s2 + 1) * y_[j - 1] + (s3 - 2 * s2 + s) * h * m_[j - 1] + (-2 * s3 + 3 * s2) * y_[j] +
           (s3 - s2) * h * m_[j];
  }

 private:
  std::vector<double> x_, y_, m_;
};

}  // namespace

TranslationalCoefficients translational_coefficients(CoefficientSet set, double alpha,
                                                     const CoefficientConstants& k) {
  switch (set) {
    case CoefficientSet::robofly: {
      // The fit does not vanish at 0 and 90 deg (0.027 and 0.103), where the lift direction reverses;
      // analytic end corrections C_L(0) cos^64 + C_L(90) sin^64 make it vanish there so that the force is
      // continuous. They change C_L by less than 2e-3 between 20 and 70 deg (the fit itself scatters more).
      const RoboflyConstants& r = k.robofly;
      auto fit = [&r](double a_deg) { return r.lift_mean + r.lift_amplitude * std::sin((r.lift_rate * a_deg - r.lift_offset_deg) * deg); };
      const double a = alpha / deg, c2 = std::pow(std::cos(alpha), 2), s2 = std::pow(std::sin(alpha), 2);
      const double lift = fit(a) - fit(0) * std::pow(c2, 32) - fit(90) * std::pow(s2, 32);
      return {lift, r.drag_mean - r.drag_amplitude * std::cos((r.drag_rate * a - r.drag_offset_deg) * deg)};
    }
    case CoefficientSet::berman_wang: {
      const BermanWangConstants& b = k.berman_wang;
      const double s = std::sin(alpha), c = std::cos(alpha);
      return {b.c_t * 2 * s * c, b.c_d_0 * c * c + b.c_d_90 * s * s};
    }
    case CoefficientSet::table: {
      // Built for each call here (the model evaluates through CoefficientFit, which calls this once per node).
      const CoefficientTable& t = k.table;
      if (t.alpha_deg.size() < 2 || t.lift.size() != t.alpha_deg.size() || t.drag.size() != t.alpha_deg.size())
        throw std::invalid_argument("quasi-steady coefficient table: needs matching alpha, lift and drag arrays");
      const double a = std::clamp(alpha / deg, t.alpha_deg.front(), t.alpha_deg.back());
      return {ClampedSpline(t.alpha_deg, t.lift)(a), ClampedSpline(t.alpha_deg, t.drag)(a)};
    }
  }
  throw std::logic_error("unknown coefficient set");
}

// Degree-9 interpolation at the Chebyshev points of each of 64 equal pieces of t in [0, 1]; the
// coefficients are entire in alpha = 2 atan(t), whose nearest singularities (t = +-i) are far from
// the pieces, so the interpolation error is at round-off level.
CoefficientFit::CoefficientFit(CoefficientSet set, const CoefficientConstants& constants) {
  constexpr int m = degree + 1;
  Eigen::Matrix<double, m, m> vandermonde;
  Eigen::Matrix<double, m, 2> values;
  for (int j = 0; j < pieces; ++j) {
    for (int k = 0; k < m; ++k) {
      const double u = std::cos(pi * (k + 0.5) / m);
      for (int p = 0; p < m; ++p) vandermonde(k, p) = std::pow(u, p);
      const TranslationalCoefficients c =
          translational_coefficients(set, 2 * std::atan((j + 0.5 * (u + 1)) / pieces), constants);
      values(k, 0) = c.lift;
      values(k, 1) = c.drag;
    }
    const Eigen::Matrix<double, m, 2> coef = vandermonde.colPivHouseholderQr().solve(values);
    for (int p = 0; p < m; ++p) {
      lift_[std::size_t(j)][std::size_t(p)] = coef(p, 0);
      drag_[std::size_t(j)][std::size_t(p)] = coef(p, 1);
    }
  }
}

TranslationalCoefficients CoefficientFit::operator()(double t) const {
  const double x = t * pieces;
  const int j = std::clamp(int(x), 0, pieces - 1);
  const double u = 2 * (x - j) - 1;
  const auto &l = lift_[std::size_t(j)], &d = drag_[std::size_t(j)];
  double cl = l[degree], cd = d[degree];
  for (int p = degree - 1; p >= 0; --p) {
    cl = cl * u + l[std::size_t(p)];
    cd = cd * u + d[std::size_t(p)];
  }
  return {cl, cd};
}

TranslationalCoefficients CoefficientFit::operator()(double t, TranslationalCoefficients& slope) const {
  const double x = t * pieces;
  const int j = std::clamp(int(x), 0, pieces - 1);
  const double u = 2 * (x - j) - 1;
  const auto &l = lift_[std::size_t(j)], &d = drag_[std::size_t(j)];
  double cl = l[degree], cd = d[degree], dl = 0, dd = 0;
  for (int p = degree - 1; p >= 0; --p) {
    dl = dl * u + cl;
    dd = dd * u + cd;
    cl = cl * u + l[std::size_t(p)];
    cd = cd * u + d[std::size_t(p)];
  }
  slope = {dl * 2 * pieces, dd * 2 * pieces};  // du/dt = 2 pieces
  return {cl, cd};
}

// Section 2: int_0^R f c dr = int_0^{pi/2} f(R sin th) c(R sin th) R cos th dth, Gauss-Legendre in th.
SpanQuadrature span_quadrature(const Wing& wing, int n) {
  if (n < 1) throw std::invalid_argument("span_quadrature: need at least one blade element");
  std::vector<double> x, w;
  gauss_legendre(n, x, w);
  SpanQuadrature q;
  q.r.resize(std::size_t(n));
  q.w.resize(std::size_t(n));
  q.c.resize(std::size_t(n));
  for (std::size_t i = 0; i < std::size_t(n); ++i) {
    const double th = pi / 4 * (1 + x[i]);
    q.r[i] = wing.length * std::sin(th);
    q.w[i] = wing.length * std::cos(th) * pi / 4 * w[i];
    q.c[i] = wing.chord(q.r[i]);
  }
  return q;
}

SpanQuadrature span_quadrature(const Insect& insect, int n) {
  SpanQuadrature q = span_quadrature(insect.wing, n);
  if (insect.hind_wing) q.hind = std::make_shared<const SpanQuadrature>(span_quadrature(*insect.hind_wing, n));
  return q;
}

QuasiSteadyModel::QuasiSteadyModel(QuasiSteadyOptions o) : opt_(o), fit_(o.coefficients, o.constants) {
  if (!(opt_.rho > 0)) throw std::invalid_argument("quasi-steady model: fluid density must be > 0");
  if (opt_.blade_elements < 1) throw std::invalid_argument("quasi-steady model: blade_elements must be >= 1");
  if (opt_.samples_per_cycle < 1) throw std::invalid_argument("quasi-steady model: samples_per_cycle must be >= 1");
}

std::string QuasiSteadyModel::name() const {
  return opt_.coefficients == CoefficientSet::robofly       ? "quasi-steady (robofly)"
         : opt_.coefficients == CoefficientSet::berman_wang ? "quasi-steady (berman-wang)"
                                                            : "quasi-steady (table)";
}

WrenchHistory QuasiSteadyModel::run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                                    const AeroRunOptions& options) const {
  if (!(kin.frequency_hz > 0)) throw std::invalid_argument("quasi-steady model: wingbeat frequency must be > 0");
  const int n = options.samples_per_cycle > 0 ? options.samples_per_cycle : opt_.samples_per_cycle;
  const Configuration config(insect, kin);
  const SpanQuadrature span = span_quadrature(insect, opt_.blade_elements);
  WrenchHistory h;
  h.samples.reserve(std::size_t(n));
  for (int k = 0; k < n; ++k) h.samples.push_back(loads(config, span, kin.period() * k / n, motion));
  return h;
}

WrenchSample QuasiSteadyModel::instantaneous(const Insect& insect, const Kinematics& kin, double t,
                                             const BodyMotion& motion) const {
  const Configuration config(insect, kin);
  return loads(config, span_quadrature(insect, opt_.blade_elements), t, motion);
}

WrenchSample QuasiSteadyModel::loads(const Configuration& config, const SpanQuadrature& span, double t,
                                     const BodyMotion& motion) const {
  WrenchSample s;
  s.time = t;
  const double x0 = config.insect().wing.pitch_axis;
  double power_right = 0, power_left = 0;
  s.right = wing_loads(config.wing_pose(Side::right, t), x0, span, motion, power_right);
  s.left = wing_loads(config.wing_pose(Side::left, t), x0, span, motion, power_left);
  s.power = power_right + power_left;
  // A hind pair adds its own blade elements; its loads join those of the wings on its side (the wings do not
  // interact aerodynamically in the quasi-steady model: no fore-hind wake interaction).
  if (const auto& hind = config.insect().hind_wing) {
    if (!span.hind) throw std::logic_error("quasi-steady loads: a four-winged insect needs span_quadrature(insect, n)");
    s.right += wing_loads(config.wing_pose(Side::right, t, Pair::hind), hind->pitch_axis, *span.hind, motion, power_right);
    s.left += wing_loads(config.wing_pose(Side::left, t, Pair::hind), hind->pitch_axis, *span.hind, motion, power_left);
    s.power += power_right + power_left;
  }
  s.body = body_loads(config, motion) + abdomen_loads(config, t, motion, nullptr);
  return s;
}

// Sections 1-6 for one wing. A wing point with hinge offset d = r e_s + x e_c moves relative to still
// air with V = V0 + r V_s + x V_c (rigid wing, steady body motion), so every per-strip quantity is a
// combination of a few per-wing vectors; strips only evaluate scalars.
Wrench QuasiSteadyModel::wing_loads(const WingPose& pose, double x0, const SpanQuadrature& span,
                                    const BodyMotion& motion, double& power) const {
  const Vec3 ec = pose.axes.col(0), es = pose.axes.col(1), en = pose.axes.col(2);
  const Vec3& w = pose.omega;
  const Vec3& wb = motion.rate;
  const Vec3 ww = wb + w;  // total wing angular velocity Omega_w
  // Section 1: V = v + Omega_b x p + omega x d with p = hinge + d.
  const Vec3 v0 = motion.velocity + wb.cross(pose.hinge), vs = ww.cross(es), vc = ww.cross(ec);
  const double v0c = v0.dot(ec), vsc = vs.dot(ec), v0n = v0.dot(en), vsn = vs.dot(en);
  // Section 4: rotation rate about the span; kappa = +1 for proper (right) axes, -1 for mirrored (left).
  const double omega_span = ww.dot(es);
  const double kappa = sgn(es.cross(en).dot(ec));
  // Section 5: d(V.n)/dt = (dV/dt|_S).n + V.(omega x n), dV/dt|_S = a_rel + Omega_b x V_rel at a wing point.
  const Vec3 ws = w.cross(es), wc = w.cross(ec), ndot = w.cross(en);
  const double as_n = (pose.omega_dot.cross(es) + w.cross(ws) + wb.cross(ws)).dot(en);
  const double ac_n = (pose.omega_dot.cross(ec) + w.cross(wc) + wb.cross(wc)).dot(en);
  const double v0_nd = v0.dot(ndot), vs_nd = vs.dot(ndot), vc_nd = vc.dot(ndot);

  const double rho = opt_.rho;
  const double c_rot = opt_.rotational_coefficient ? *opt_.rotational_coefficient : pi * (0.75 - x0);
  double f_c = 0, f_n = 0;              // force components along e_c and e_n
  double m_rc = 0, m_rn = 0, m_xn = 0;  // sums of r f_c, r f_n and x f_n (x: chordwise application point)
  for (std::size_t i = 0; i < span.r.size(); ++i) {
    const double r = span.r[i], c = span.c[i], dr = span.w[i];
    // Section 1: air velocity relative to the strip's pitch-axis point, spanwise part removed.
    const double uc = -(v0c + r * vsc), un = -(v0n + r * vsn);
    const double u2 = uc * uc + un * un, u = std::sqrt(u2);
    double fc = 0, fn = 0;  // circulatory, at the quarter chord
    if (u > 0) {
      // Section 3: alpha = angle between chord line and U_perp in [0, 90 deg]; tan(alpha/2) = |U_n| / (|U| + |U_c|).
      const TranslationalCoefficients k = fit_(std::abs(un) / (u + std::abs(uc)));
      // dF = 1/2 rho |U| c dr [C_D U_perp + C_L sigma (U_c e_n - U_n e_c)], sigma = sgn(U_c) sgn(U_n).
      const double q = 0.5 * rho * u * c * dr, sigma = sgn(uc) * sgn(un);
      fc = q * (k.drag * uc - sigma * k.lift * un);
      fn = q * (k.drag * un + sigma * k.lift * uc);
    }
    // Section 4: rotational circulation Gamma = C_rot c^2 alphadot (Sane & Dickinson 2002; thin-aerofoil
    // theory) with its Kutta-Joukowski force rho Gamma x U, perpendicular to U_perp: continuous through
    // every angle of attack, so the cycle means are differentiable in the body velocities.
    if (opt_.rotational) {
      const double g = c_rot * rho * c * c * dr * kappa * omega_span;
      fc -= g * un;
      fn += g * uc;
    }
    const double xq = (x0 - opt_.centre_of_pressure) * c;
    f_c += fc;
    f_n += fn;
    m_rc += r * fc;
    m_rn += r * fn;
    m_xn += xq * fn;
    if (opt_.added_mass) {
      // Section 5: dF_am = -rho pi/4 c^2 dr d(w_mid)/dt along e_n, at the mid chord x_m = (x0 - 1/2) c.
      const double xm = (x0 - 0.5) * c;
      const double wdot = r * as_n + xm * ac_n + v0_nd + r * vs_nd + xm * vc_nd;
      const double fam = -rho * pi / 4 * c * c * dr * wdot;
      f_n += fam;
      m_rn += r * fam;
      m_xn += xm * fam;
    }
  }
  // Section 7: moment about O = hinge x F + sum (r e_s + x e_c) x (f_c e_c + f_n e_n).
  Wrench out;
  out.force = f_c * ec + f_n * en;
  out.moment = pose.hinge.cross(out.force) + m_rc * es.cross(ec) + m_rn * es.cross(en) + m_xn * ec.cross(en);
  // Section 7: P = -sum dF . V_rel, V_rel = r (omega x e_s) + x (omega x e_c); (omega x e_c).e_c = 0.
  power = -(ws.dot(ec) * m_rc + ws.dot(en) * m_rn + wc.dot(en) * m_xn);
  return out;
}

// Section 9: the same sums differentiated. Every per-wing scalar the strips use is linear in the body motion
// m = [velocity; rate]: uc = -(v0c + r vsc), un = -(v0n + r vsn) and omega_span for the circulatory and rotational
// forces, (as_n, ac_n, v0_nd, vs_nd, vc_nd) for the added mass. Each strip contributes the partial derivatives of
// its forces with respect to those scalars (weighted by 1, r, x for the five sums); the sums' gradients follow by
// the chain rule with the scalars' constant gradients in m.
Wrench QuasiSteadyModel::wing_loads_jacobian(const WingPose& pose, double x0, const SpanQuadrature& span,
                                             const BodyMotion& motion, Eigen::Matrix<double, 6, 6>& jac) const {
  const Vec3 ec = pose.axes.col(0), es = pose.axes.col(1), en = pose.axes.col(2);
  const Vec3& w = pose.omega;
  const Vec3& wb = motion.rate;
  const Vec3 ww = wb + w;
  const Vec3 v0 = motion.velocity + wb.cross(pose.hinge), vs = ww.cross(es), vc = ww.cross(ec);
  const double v0c = v0.dot(ec), vsc = vs.dot(ec), v0n = v0.dot(en), vsn = vs.dot(en);
  const double omega_span = ww.dot(es);
  const double kappa = sgn(es.cross(en).dot(ec));
  const Vec3 ws = w.cross(es), wc = w.cross(ec), ndot = w.cross(en);
  const double as_n = (pose.omega_dot.cross(es) + w.cross(ws) + wb.cross(ws)).dot(en);
  const double ac_n = (pose.omega_dot.cross(ec) + w.cross(wc) + wb.cross(wc)).dot(en);
  const double v0_nd = v0.dot(ndot), vs_nd = vs.dot(ndot), vc_nd = vc.dot(ndot);

  // Gradients in m of the circulatory inputs [v0c, vsc, v0n, vsn, omega_span] and the added-mass inputs
  // [as_n, ac_n, v0_nd, vs_nd, vc_nd] ((a x b).c = a.(b x c) for the rate parts).
  Eigen::Matrix<double, 5, 6> g_in = Eigen::Matrix<double, 5, 6>::Zero(), g_am = Eigen::Matrix<double, 5, 6>::Zero();
  const Vec3& h = pose.hinge;
  g_in.row(0) << ec.transpose(), h.cross(ec).transpose();
  g_in.row(1).tail<3>() = es.cross(ec);
  g_in.row(2) << en.transpose(), h.cross(en).transpose();
  g_in.row(3).tail<3>() = es.cross(en);
  g_in.row(4).tail<3>() = es;
  g_am.row(0).tail<3>() = ws.cross(en);
  g_am.row(1).tail<3>() = wc.cross(en);
  g_am.row(2) << ndot.transpose(), h.cross(ndot).transpose();
  g_am.row(3).tail<3>() = es.cross(ndot);
  g_am.row(4).tail<3>() = ec.cross(ndot);

  const double rho = opt_.rho;
  const double c_rot = opt_.rotational_coefficient ? *opt_.rotational_coefficient : pi * (0.75 - x0);
  double f_c = 0, f_n = 0, m_rc = 0, m_rn = 0, m_xn = 0;
  // Rows: d[f_c, f_n, m_rc, m_rn, m_xn] / d(inputs).
  Eigen::Matrix<double, 5, 5> d_in = Eigen::Matrix<double, 5, 5>::Zero(), d_am = Eigen::Matrix<double, 5, 5>::Zero();
  for (std::size_t i = 0; i < span.r.size(); ++i) {
    const double r = span.r[i], c = span.c[i], dr = span.w[i];
    const double uc = -(v0c + r * vsc), un = -(v0n + r * vsn);
    const double u2 = uc * uc + un * un, u = std::sqrt(u2);
    double fc = 0, fn = 0;
    double a = 0, b = 0, cc = 0, d = 0;  // dfc/duc, dfc/dun, dfn/duc, dfn/dun
    if (u > 0) {
      const double sc = sgn(uc), sn = sgn(un);
      const double A = u + std::abs(uc), t = std::abs(un) / A;
      TranslationalCoefficients dk;
      const TranslationalCoefficients k = fit_(t, dk);
      const double dA_duc = uc / u + sc, dA_dun = un / u;
      const double dt_duc = -t * dA_duc / A, dt_dun = (sn - t * dA_dun) / A;
      const double Q = 0.5 * rho * c * dr, q = Q * u, sigma = sc * sn;
      const double gc = k.drag * uc - sigma * k.lift * un, gn = k.drag * un + sigma * k.lift * uc;
      fc = q * gc;
      fn = q * gn;
      const double du_duc = uc / u, du_dun = un / u;
      a = Q * du_duc * gc + q * ((dk.drag * uc - sigma * dk.lift * un) * dt_duc + k.drag);
      b = Q * du_dun * gc + q * ((dk.drag * uc - sigma * dk.lift * un) * dt_dun - sigma * k.lift);
      cc = Q * du_duc * gn + q * ((dk.drag * un + sigma * dk.lift * uc) * dt_duc + sigma * k.lift);
      d = Q * du_dun * gn + q * ((dk.drag * un + sigma * dk.lift * uc) * dt_dun + k.drag);
    }
    double e = 0, f = 0;  // dfc/domega_span, dfn/domega_span
    if (opt_.rotational) {
      const double G = c_rot * rho * c * c * dr * kappa, g = G * omega_span;
      fc -= g * un;
      fn += g * uc;
      b -= g;
      cc += g;
      e = -G * un;
      f = G * uc;
    }
    const double xq = (x0 - opt_.centre_of_pressure) * c;
    f_c += fc;
    f_n += fn;
    m_rc += r * fc;
    m_rn += r * fn;
    m_xn += xq * fn;
    // uc and un are -(v0c + r vsc) and -(v0n + r vsn).
    Eigen::Matrix<double, 1, 5> pc, pn;
    pc << -a, -a * r, -b, -b * r, e;
    pn << -cc, -cc * r, -d, -d * r, f;
    d_in.row(0) += pc;
    d_in.row(1) += pn;
    d_in.row(2) += r * pc;
    d_in.row(3) += r * pn;
    d_in.row(4) += xq * pn;
    if (opt_.added_mass) {
      const double xm = (x0 - 0.5) * c;
      const double wdot = r * as_n + xm * ac_n + v0_nd + r * vs_nd + xm * vc_nd;
      const double k_am = -rho * pi / 4 * c * c * dr, fam = k_am * wdot;
      f_n += fam;
      m_rn += r * fam;
      m_xn += xm * fam;
      Eigen::Matrix<double, 1, 5> pa;
      pa << k_am * r, k_am * xm, k_am, k_am * r, k_am * xm;
      d_am.row(1) += pa;
      d_am.row(3) += r * pa;
      d_am.row(4) += xm * pa;
    }
  }
  const Eigen::Matrix<double, 5, 6> d_sums = d_in * g_in + d_am * g_am;
  Wrench out;
  out.force = f_c * ec + f_n * en;
  out.moment = pose.hinge.cross(out.force) + m_rc * es.cross(ec) + m_rn * es.cross(en) + m_xn * ec.cross(en);
  const Eigen::Matrix<double, 3, 6> dF = ec * d_sums.row(0) + en * d_sums.row(1);
  jac.topRows<3>() = dF;
  jac.bottomRows<3>() = skew(pose.hinge) * dF + es.cross(ec) * d_sums.row(2) + es.cross(en) * d_sums.row(3) +
                        ec.cross(en) * d_sums.row(4);
  return out;
}

Wrench QuasiSteadyModel::loads_jacobian(const Configuration& config, const SpanQuadrature& span, double t,
                                        const BodyMotion& motion, Eigen::Matrix<double, 6, 6>& jacobian) const {
  const double x0 = config.insect().wing.pitch_axis;
  Eigen::Matrix<double, 6, 6> jr, jl;
  Wrench total = wing_loads_jacobian(config.wing_pose(Side::right, t), x0, span, motion, jr);
  total += wing_loads_jacobian(config.wing_pose(Side::left, t), x0, span, motion, jl);
  jacobian = jr + jl;
  if (const auto& hind = config.insect().hind_wing) {
    if (!span.hind) throw std::logic_error("quasi-steady loads: a four-winged insect needs span_quadrature(insect, n)");
    total += wing_loads_jacobian(config.wing_pose(Side::right, t, Pair::hind), hind->pitch_axis, *span.hind, motion, jr);
    total += wing_loads_jacobian(config.wing_pose(Side::left, t, Pair::hind), hind->pitch_axis, *span.hind, motion, jl);
    jacobian += jr + jl;
  }
  // Section 6's body drag: F = R_SA f_A(v_A), v_A = R_SA^T (v + Omega x p_c), df_A,i / dv_A,i = -rho C_D A_i |v_A,i|.
  const Body& bd = config.insect().body;
  const Wrench body = body_loads(config, motion);
  total += body;
  if (bd.drag_coefficient > 0) {
    const Mat3& r_sa = config.anatomical_to_stability();
    const Vec3 pc = config.body_centre();
    const Vec3 va = r_sa.transpose() * (motion.velocity + motion.rate.cross(pc));
    const Vec3 area = pi / 4 * Vec3(bd.width * bd.height, bd.length * bd.height, bd.length * bd.width);
    const Vec3 dfa = -opt_.rho * bd.drag_coefficient * area.cwiseProduct(va.cwiseAbs());
    Eigen::Matrix<double, 3, 6> dva;
    dva << r_sa.transpose(), -r_sa.transpose() * skew(pc);
    const Eigen::Matrix<double, 3, 6> dF = r_sa * dfa.asDiagonal() * dva;
    jacobian.topRows<3>() += dF;
    jacobian.bottomRows<3>() += skew(pc) * dF;
  }
  total += abdomen_loads(config, t, motion, &jacobian);
  return total;
}

// The abdomen's drag, as the thorax's (section 6) on the abdomen's own ellipsoid and axes R = R_SA R_y(eta): its
// centre p (the abdomen CoM, from O) moves at v + Omega x p + eta' e_y x (p - joint), the last the flexion's own
// velocity relative to the thorax. v_A = R^T (...), f_A,i = -rho C_D A_i |v_A,i| v_A,i / 2, F = R f_A, M = p x F;
// d v_A / d[v; Omega] = R^T [I, -skew(p)], d f_A,i / d v_A,i = -rho C_D A_i |v_A,i|.
Wrench QuasiSteadyModel::abdomen_loads(const Configuration& config, double t, const BodyMotion& motion,
                                       Eigen::Matrix<double, 6, 6>* jacobian) const {
  Wrench out;
  const auto& ab = config.insect().abdomen;
  if (!ab || !(ab->drag_coefficient > 0)) return out;
  Mat3 R;
  double rate = 0;
  const Vec3 cg = config.abdomen_cg_about_body_cg(t, &R, &rate);  // from the thorax CoM, S axes
  const Vec3 p = config.body_centre() + cg;
  const Vec3 relative = Vec3(0, rate, 0).cross(R * ab->centre);
  const Vec3 va = R.transpose() * (motion.velocity + motion.rate.cross(p) + relative);
  const Vec3& d = ab->diameters;
  const Vec3 area = pi / 4 * Vec3(d.y() * d.z(), d.x() * d.z(), d.x() * d.y());
  const Vec3 fa = -0.5 * opt_.rho * ab->drag_coefficient * area.cwiseProduct(va.cwiseAbs()).cwiseProduct(va);
  out.force = R * fa;
  out.moment = p.cross(out.force);
  if (jacobian) {
    const Vec3 dfa = -opt_.rho * ab->drag_coefficient * area.cwiseProduct(va.cwiseAbs());
    Eigen::Matrix<double, 3, 6> dva;
    dva << R.transpose(), -R.transpose() * skew(p);
    const Eigen::Matrix<double, 3, 6> dF = R * dfa.asDiagonal() * dva;
    jacobian->topRows<3>() += dF;
    jacobian->bottomRows<3>() += skew(p) * dF;
  }
  return out;
}

// Section 6: quadratic body drag per anatomical axis on the projected ellipse areas, at the body CoM.
Wrench QuasiSteadyModel::body_loads(const Configuration& config, const BodyMotion& motion) const {
  const Body& b = config.insect().body;
  Wrench out;
  if (!(b.drag_coefficient > 0)) return out;
  const Mat3& r_sa = config.anatomical_to_stability();
  const Vec3 pc = config.body_centre();
  const Vec3 va = r_sa.transpose() * (motion.velocity + motion.rate.cross(pc));
  const Vec3 area = pi / 4 * Vec3(b.width * b.height, b.length * b.height, b.length * b.width);
  const Vec3 fa = -0.5 * opt_.rho * b.drag_coefficient * area.cwiseProduct(va.cwiseAbs()).cwiseProduct(va);
  out.force = r_sa * fa;
  out.moment = pc.cross(out.force);
  return out;
}

}  // namespace flapstab
