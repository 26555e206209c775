// Tests of the quasi-steady blade-element model (cfd/quasi_steady) against symmetry and closed forms.
//
// Closed forms (docs/theory/quasi-steady.md): revolving wing L = 1/2 rho Omega^2 C_L int r^2 c dr
// (blade-element integral, Sane & Dickinson 2001); added mass -rho pi/4 phi'' int r c^2 dr and
// rotational force C_rot rho phi' alpha' int r c^2 dr (Sane & Dickinson 2002). Planform integrals are
// exact for the elliptic chord c = (4 c_bar/pi) sqrt(1 - (r/R)^2) (Berman & Wang 2007) and the
// rectangular one.
#include <gtest/gtest.h>
#include <cmath>
#include "cfd/quasi_steady/quasi_steady.hpp"
#include "core/configuration.hpp"
#include "core/rotation.hpp"

namespace flapstab {
namespace {

constexpr double rho = 1.225;
constexpr double R = 0.05, cbar = 0.018;  // hawkmoth-sized wing (Berman & Wang 2007, J Fluid Mech 582:153, Table 2: R 51.9 mm, c 18.26 mm)

Insect test_insect(Planform planform, double pitch_axis = 0.25, double body_drag = 0) {
  Insect in;
  in.name = "test";
  in.body.mass = 1.5e-3;
  in.body.length = 0.04;
  in.body.width = 0.01;
  in.body.height = 0.01;
  in.body.inertia = in.body.ellipsoid_inertia();
  in.body.drag_coefficient = body_drag;
  in.wing.length = R;
  in.wing.mean_chord = cbar;
  in.wing.planform = planform;
  in.wing.pitch_axis = pitch_axis;
  in.wing.mass = 5e-5;
  Mat3 inertia_hinge;
  in.wing.plate_mass_properties(in.wing.mass_centre, inertia_hinge);
  const Vec3& m = in.wing.mass_centre;
  in.wing.inertia_cg = inertia_hinge - in.wing.mass * (m.squaredNorm() * Mat3::Identity() - m * m.transpose());
  in.wing.hinge = Vec3(0.006, 0.003, -0.003);
  return in;
}

FourierSeries fourier(double mean_deg, std::vector<double> cos_deg, std::vector<double> sin_deg) {
  for (double& x : cos_deg) x *= deg;
  for (double& x : sin_deg) x *= deg;
  return {mean_deg * deg, cos_deg, sin_deg};
}

// Hover-like harmonic kinematics: downstroke (phi increasing) for tau in (0.5, 1) at 40 deg incidence,
// upstroke at alpha = 140 deg, symmetric rotation at the reversals, a figure-of-eight deviation.
WingAngles hover_wing(double amplitude_deg = 60, double phase = 0) {
  WingAngles w;
  w.stroke = fourier(5, {amplitude_deg * std::cos(phase)}, {amplitude_deg * std::sin(phase)});
  w.deviation = fourier(0, {0, 4}, {0, 6});
  w.pitch = fourier(90, {0, 3}, {50, 0});
  return w;
}

Kinematics kinematics(const WingAngles& right, const WingAngles& left, double beta = 0.1, double chi = 0.6) {
  Kinematics k;
  k.frequency_hz = 26;
  k.stroke_plane = beta;
  k.body_angle = chi;
  k.right = right;
  k.left = left;
  return k;
}

QuasiSteadyModel model(CoefficientSet set, bool rotational = true, bool added_mass = true) {
  QuasiSteadyOptions o;
  o.rho = rho;
  o.coefficients = set;
  o.rotational = rotational;
  o.added_mass = added_mass;
  return QuasiSteadyModel(o);
}

// Exact planform integrals int_0^R r^k c^m dr.
double planform_integral(Planform p, int k, int m) {
  if (p == Planform::rectangular) return std::pow(cbar, m) * std::pow(R, k + 1) / (k + 1);
  // elliptic: (4 cbar/pi)^m R^(k+1) int_0^1 x^k (1-x^2)^(m/2) dx = ... B((k+1)/2, m/2+1) / 2
  const double beta = std::tgamma((k + 1) / 2.0) * std::tgamma(m / 2.0 + 1) / std::tgamma((k + 1) / 2.0 + m / 2.0 + 1);
  return std::pow(4 * cbar / pi, m) * std::pow(R, k + 1) * beta / 2;
}

Vec3 mirror_force(const Vec3& f) { return mirror_y() * f; }
Vec3 mirror_moment(const Vec3& m) { return -(mirror_y() * m); }  // pseudovector

// ---------------------------------------------------------------------------------------------------

// Quadrature: Gauss-Legendre in theta (r = R sin theta) integrates r^k c for the elliptic planform to
// round-off with 40 nodes (the midpoint rule's error is O(n^-1.5) there: ~1e-3 at n = 40).
TEST(QuasiSteadyQuadrature, IntegratesPlanformMomentsToRoundOff) {
  for (Planform p : {Planform::elliptic, Planform::rectangular}) {
    const Insect in = test_insect(p);
    const SpanQuadrature q = span_quadrature(in.wing, 40);
    for (int k : {0, 1, 2, 3}) {
      for (int m : {1, 2, 3}) {
        double s = 0;
        for (std::size_t i = 0; i < q.r.size(); ++i) s += q.w[i] * std::pow(q.r[i], k) * std::pow(q.c[i], m - 1) * q.c[i];
        const double exact = planform_integral(p, k, m);
        EXPECT_NEAR(s / exact, 1.0, 1e-13) << "planform " << int(p) << " k " << k << " m " << m;
      }
    }
  }
  // The midpoint rule with the same 40 strips misses the elliptic area by more than 1e-4 (relative):
  // the reason for the substitution.
  const Insect in = test_insect(Planform::elliptic);
  double mid = 0;
  for (int i = 0; i < 40; ++i) mid += in.wing.chord((i + 0.5) * R / 40) * R / 40;
  EXPECT_GT(std::abs(mid / (cbar * R) - 1), 1e-4);
}

// Coefficient sets at their documented values: Robofly C_L = 0.225 + 1.58 sin(2.13 a - 7.2 deg),
// C_D = 1.92 - 1.55 cos(2.04 a - 9.82 deg), with the end corrections that make C_L vanish at 0 and
// 90 deg (within 1e-9 of the fit at 45 deg and within 2e-3 over 20-70 deg); Berman & Wang
// C_L(45 deg) = C_T = 1.678, C_D(0) = 0.07, C_D(90 deg) = 3.06 (to 1e-12).
TEST(QuasiSteadyCoefficients, MatchPublishedForms) {
  auto fit = [](double a) { return 0.225 + 1.58 * std::sin((2.13 * a - 7.2) * deg); };
  const auto r0 = translational_coefficients(CoefficientSet::robofly, 0);
  EXPECT_NEAR(r0.lift, 0.0, 1e-15);
  EXPECT_NEAR(translational_coefficients(CoefficientSet::robofly, pi / 2).lift, 0.0, 1e-15);
  EXPECT_NEAR(r0.drag, 1.92 - 1.55 * std::cos(-9.82 * deg), 1e-12);
  const auto r45 = translational_coefficients(CoefficientSet::robofly, 45 * deg);
  EXPECT_NEAR(r45.lift, fit(45), 1e-9);
  for (double a = 20; a <= 70; a += 1)
    EXPECT_NEAR(translational_coefficients(CoefficientSet::robofly, a * deg).lift, fit(a), 2e-3) << a;
  const auto b45 = translational_coefficients(CoefficientSet::berman_wang, 45 * deg);
  EXPECT_NEAR(b45.lift, 1.678, 1e-12);
  EXPECT_NEAR(translational_coefficients(CoefficientSet::berman_wang, 0).drag, 0.07, 1e-12);
  EXPECT_NEAR(translational_coefficients(CoefficientSet::berman_wang, pi / 2).drag, 3.06, 1e-12);
  EXPECT_NEAR(translational_coefficients(CoefficientSet::berman_wang, pi / 2).lift, 0.0, 1e-12);
}

// The model's hot loop evaluates the coefficients through a piecewise polynomial in tan(alpha/2);
// it reproduces the definitions to 1e-14 (absolute; the coefficients are O(1)) over [0, 90 deg].
TEST(QuasiSteadyCoefficients, FitReproducesDefinitions) {
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    const CoefficientFit fit(set);
    double err = 0;
    for (int i = 0; i <= 10000; ++i) {
      const double alpha = pi / 2 * i / 10000;
      const TranslationalCoefficients a = fit(std::tan(alpha / 2)), b = translational_coefficients(set, alpha);
      err = std::max({err, std::abs(a.lift - b.lift), std::abs(a.drag - b.drag)});
    }
    EXPECT_LT(err, 1e-14) << "set " << int(set);
  }
}

// Coefficients as data ([aero.quasi_steady]): constants equal to the published ones change nothing (bit for bit), and
// other constants enter the published forms.
TEST(QuasiSteadyCoefficients, ConstantsEnterThePublishedForms) {
  CoefficientConstants k;
  k.robofly.lift_amplitude = 1.2;
  k.robofly.drag_mean = 2.0;
  k.berman_wang.c_t = 1.5;
  k.berman_wang.c_d_0 = 0.1;
  k.berman_wang.c_d_90 = 3.4;
  const double a = 40 * deg;
  const auto r = translational_coefficients(CoefficientSet::robofly, a, k);
  auto fit = [](double x) { return 0.225 + 1.2 * std::sin((2.13 * x - 7.2) * deg); };
  // With the end terms fit(0) cos^64 + fit(90) sin^64 (docs/theory/quasi-steady.md section 3).
  EXPECT_NEAR(r.lift, fit(40) - fit(0) * std::pow(std::cos(a), 64) - fit(90) * std::pow(std::sin(a), 64), 1e-14);
  EXPECT_NEAR(r.drag, 2.0 - 1.55 * std::cos((2.04 * 40 - 9.82) * deg), 1e-14);
  const auto b = translational_coefficients(CoefficientSet::berman_wang, a, k);
  EXPECT_NEAR(b.lift, 1.5 * std::sin(2 * a), 1e-14);
  EXPECT_NEAR(b.drag, 0.1 * std::pow(std::cos(a), 2) + 3.4 * std::pow(std::sin(a), 2), 1e-14);
  for (double x = 0; x <= 90; x += 0.5)
    for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
      const auto d = translational_coefficients(set, x * deg), e = translational_coefficients(set, x * deg, {});
      EXPECT_EQ(d.lift, e.lift);
      EXPECT_EQ(d.drag, e.drag);
    }
}

// A user table sampling a built-in set at 1 deg reproduces it to the accuracy of the clamped cubic spline. Its error is
// largest in the end intervals, from the third-order end slopes (slope error <= h^3 max|f^(4)| / 4, giving at most
// 4/27 h x that): h^4 max|f^(4)| / 27 with h = 1 deg = 0.01745 rad (h^4 = 9.3e-8). The Robofly end term
// C_L(90) sin^64 alpha has max|f^(4)| ~ 0.103 x 3 x 64^2 = 1265 at 90 deg: bound 4.4e-6 (measured 4.2e-6); Berman-Wang's
// C_T sin 2 alpha has max|f^(4)| = 16 C_T = 26.8: bound 9.3e-8 (measured 8.9e-8). The loads, linear in the coefficients, differ by at most the
// coefficient error over the peak coefficient (~ 3) as a fraction of the peak force: 2e-6 stated for both sets.
TEST(QuasiSteadyCoefficients, TableOfTheFitReproducesIt) {
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    QuasiSteadyOptions o;
    o.rho = rho;
    o.coefficients = CoefficientSet::table;
    for (int i = 0; i <= 90; ++i) {
      const auto c = translational_coefficients(set, i * deg);
      o.constants.table.alpha_deg.push_back(i);
      o.constants.table.lift.push_back(c.lift);
      o.constants.table.drag.push_back(c.drag);
    }
    double err = 0;
    for (int i = 0; i <= 9000; ++i) {
      const double alpha = pi / 2 * i / 9000;
      const auto a = translational_coefficients(CoefficientSet::table, alpha, o.constants),
                 b = translational_coefficients(set, alpha);
      err = std::max({err, std::abs(a.lift - b.lift), std::abs(a.drag - b.drag)});
    }
    EXPECT_LT(err, set == CoefficientSet::robofly ? 4.5e-6 : 9.5e-8) << "set " << int(set);
    const QuasiSteadyModel table(o);
    const Insect in = test_insect(Planform::elliptic, 0.3, 0.5);
    const Kinematics kin = kinematics(hover_wing(), hover_wing(70, 0.1));
    BodyMotion m;
    m.velocity = Vec3(0.2, -0.1, 0.3);
    m.rate = Vec3(1, 3, -2);
    const WrenchHistory h = table.run(in, kin, m, {}), g = model(set).run(in, kin, m, {});
    double peak = 0, diff = 0;
    for (std::size_t k = 0; k < h.samples.size(); ++k) {
      peak = std::max(peak, g.samples[k].total().force.norm());
      diff = std::max({diff, (h.samples[k].total().force - g.samples[k].total().force).norm(),
                       (h.samples[k].total().moment - g.samples[k].total().moment).norm() / R});
    }
    EXPECT_LT(diff, 2e-6 * peak) << "set " << int(set);
  }
}

// The centre of pressure moves only the chordwise lever of the circulatory (translational + rotational) force: on a
// rectangular wing without added mass, moving it from x1 to x2 (chord fractions from the LE) leaves every force
// unchanged (bit for bit) and changes each wing's moment by (x1 - x2) c F_n (e_c x e_n), F_n its normal force.
// The rotational coefficient replaces pi (3/4 - x0): given as that value nothing changes; 0 is rotational = false.
TEST(QuasiSteadyCoefficients, CentreOfPressureAndRotationalCoefficient) {
  const Insect in = test_insect(Planform::rectangular, 0.3, 0);
  const Kinematics kin = kinematics(hover_wing(), hover_wing(70, 0.1));
  const Configuration config(in, kin);
  const SpanQuadrature span = span_quadrature(in.wing, 40);
  BodyMotion m;
  m.velocity = Vec3(0.2, -0.1, 0.3);
  m.rate = Vec3(1, 3, -2);
  QuasiSteadyOptions o;
  o.rho = rho;
  o.added_mass = false;
  const QuasiSteadyModel quarter(o);
  o.centre_of_pressure = 0.6;
  const QuasiSteadyModel aft(o);
  for (double t : {0.1, 0.37, 0.8}) {
    const double time = t * kin.period();
    const WrenchSample a = quarter.loads(config, span, time, m), b = aft.loads(config, span, time, m);
    for (Side side : {Side::right, Side::left}) {
      const Wrench& wa = side == Side::right ? a.right : a.left;
      const Wrench& wb = side == Side::right ? b.right : b.left;
      EXPECT_EQ((wa.force - wb.force).norm(), 0.0);
      const WingPose pose = config.wing_pose(side, time);
      const Vec3 ec = pose.axes.col(0), en = pose.axes.col(2);
      const Vec3 expected = (0.25 - 0.6) * cbar * wa.force.dot(en) * ec.cross(en);
      EXPECT_LT((wb.moment - wa.moment - expected).norm(), 1e-12 * wa.force.norm() * R);
    }
  }
  QuasiSteadyOptions r;
  r.rho = rho;
  const QuasiSteadyModel plain(r);
  r.rotational_coefficient = pi * (0.75 - 0.3);
  const QuasiSteadyModel same(r);
  r.rotational_coefficient = 0.0;
  const QuasiSteadyModel zero(r);
  r.rotational_coefficient.reset();
  r.rotational = false;
  const QuasiSteadyModel none(r);
  for (double t : {0.1, 0.37, 0.8}) {
    const Wrench p = plain.loads(config, span, t * kin.period(), m).total(),
                 s = same.loads(config, span, t * kin.period(), m).total(),
                 z = zero.loads(config, span, t * kin.period(), m).total(),
                 n = none.loads(config, span, t * kin.period(), m).total();
    EXPECT_EQ((p.force - s.force).norm(), 0.0);
    EXPECT_EQ((p.moment - s.moment).norm(), 0.0);
    EXPECT_EQ((z.force - n.force).norm(), 0.0);
    EXPECT_EQ((z.moment - n.moment).norm(), 0.0);
    EXPECT_GT((p.force - n.force).norm(), 1e-6 * p.force.norm());  // the rotational force is there
  }
}

// 1. Symmetric kinematics and a longitudinal body motion: Fy = L = N = 0 at every instant and in the
// mean, to round-off (1e-12 of the peak vertical force, moments also divided by R).
TEST(QuasiSteadySymmetry, SymmetricKinematicsGiveNoLateralLoads) {
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    const Insect in = test_insect(Planform::elliptic, 0.3, 0.5);
    const Kinematics kin = kinematics(hover_wing(), hover_wing());
    BodyMotion m;
    m.velocity = Vec3(0.3, 0, 0.2);
    m.rate = Vec3(0, 4, 0);
    const WrenchHistory h = model(set).run(in, kin, m, {});
    double fz = 0;
    for (const auto& s : h.samples) fz = std::max(fz, std::abs(s.total().force.z()));
    ASSERT_GT(fz, 1e-4);  // the test is meaningful: the wings carry load
    for (const auto& s : h.samples) {
      const Wrench w = s.total();
      EXPECT_LE(std::abs(w.force.y()), 1e-12 * fz);
      EXPECT_LE(std::abs(w.moment.x()), 1e-12 * fz * R);
      EXPECT_LE(std::abs(w.moment.z()), 1e-12 * fz * R);
    }
    const Wrench mean = h.mean();
    EXPECT_LE(std::abs(mean.force.y()), 1e-12 * fz);
    EXPECT_LE(std::abs(mean.moment.x()), 1e-12 * fz * R);
    EXPECT_LE(std::abs(mean.moment.z()), 1e-12 * fz * R);
  }
}

// 2. Different right and left kinematics, then swapped, with the body motion mirrored (v, p, r
// negated): the loads are mirror images part by part (forces y -> -y, moments x, z -> -x, -z), 1e-12.
TEST(QuasiSteadySymmetry, SwappedKinematicsGiveMirrorImageLoads) {
  const Insect in = test_insect(Planform::rectangular, 0.2, 0.5);
  const WingAngles a = hover_wing(65, 0.1), b = hover_wing(50, -0.2);
  const Kinematics k1 = kinematics(a, b), k2 = kinematics(b, a);
  BodyMotion m1, m2;
  m1.velocity = Vec3(0.2, 0.3, -0.1);
  m1.rate = Vec3(3, -2, 5);
  m2.velocity = mirror_force(m1.velocity);
  m2.rate = mirror_moment(m1.rate);
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    const QuasiSteadyModel qs = model(set);
    const WrenchHistory h1 = qs.run(in, k1, m1, {}), h2 = qs.run(in, k2, m2, {});
    ASSERT_EQ(h1.samples.size(), h2.samples.size());
    double scale = 0;
    for (const auto& s : h1.samples) scale = std::max(scale, s.total().force.norm());
    ASSERT_GT(std::abs(h1.mean().force.y()), 1e-3 * scale);  // asymmetric indeed
    auto expect_mirror = [&](const Wrench& p, const Wrench& q) {
      EXPECT_LE((p.force - mirror_force(q.force)).norm(), 1e-12 * scale);
      EXPECT_LE((p.moment - mirror_moment(q.moment)).norm(), 1e-12 * scale * R);
    };
    for (std::size_t i = 0; i < h1.samples.size(); ++i) {
      const WrenchSample &s1 = h1.samples[i], &s2 = h2.samples[i];
      expect_mirror(s1.right, s2.left);
      expect_mirror(s1.left, s2.right);
      expect_mirror(s1.body, s2.body);
      EXPECT_NEAR(s1.power, s2.power, 1e-12 * scale * R * 2 * pi * 26);
    }
  }
}

// 3. Wing revolving at constant angle of attack: phi = A sin(2 pi n t) at t = 0 (phi' = 2 pi n A maximal,
// phi'' = 0), constant pitch. Per wing, in the stroke-plane frame: F = 1/2 rho phi'^2 int r^2 c dr
// (-C_D, 0, -C_L); moment about the hinge from the quarter-chord centre of pressure; power
// 1/2 rho |phi'|^3 C_D int r^3 c dr. Rotational and added-mass terms vanish. Relative tolerance 1e-12.
TEST(QuasiSteadyClosedForm, RevolvingWingMatchesBladeElementIntegral) {
  const double A = 60 * deg, beta = 0.3;
  for (Planform p : {Planform::elliptic, Planform::rectangular}) {
    for (double x0 : {0.25, 0.4}) {
      for (double incidence : {20 * deg, 35 * deg, 70 * deg}) {
        const Insect in = test_insect(p, x0);
        WingAngles w;
        w.stroke = FourierSeries{0, {0}, {A}};
        w.pitch = FourierSeries{incidence, {}, {}};
        const Kinematics kin = kinematics(w, w, beta, 0.5);
        const Configuration config(in, kin);
        const double dphi = 2 * pi * kin.frequency_hz * A;
        const double i2 = planform_integral(p, 2, 1), i3 = planform_integral(p, 3, 1);
        const double i2c2 = planform_integral(p, 2, 2);
        for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
          for (bool unsteady : {true, false}) {
            const QuasiSteadyModel qs = model(set, unsteady, unsteady);
            const WrenchSample s = qs.instantaneous(in, kin, 0.0, {});
            const TranslationalCoefficients k = translational_coefficients(set, incidence);
            const Mat3 rsp = rot_y(beta);
            const double q = 0.5 * rho * dphi * dphi;
            const Vec3 per_r = rsp * Vec3(-k.drag, 0, -k.lift);  // force per 1/2 rho phi'^2 r^2 c dr
            const Vec3 f = q * i2 * per_r;
            EXPECT_LE((s.right.force - f).norm(), 1e-12 * f.norm());
            EXPECT_LE((s.left.force - f).norm(), 1e-12 * f.norm());
            // Moment about O: hinge x F + int (r e_s + (x0 - 1/4) c e_c) x dF.
            const WingPose pose = config.wing_pose(Side::right, 0.0);
            const Vec3 es = rsp * Vec3::UnitY(), ec = rsp * Vec3(std::cos(incidence), 0, -std::sin(incidence));
            const Vec3 m = pose.hinge.cross(f) + q * i3 * es.cross(per_r) + q * (x0 - 0.25) * i2c2 * ec.cross(per_r);
            EXPECT_LE((s.right.moment - m).norm(), 1e-12 * f.norm() * R);
            EXPECT_NEAR(s.power, 2 * 0.5 * rho * dphi * dphi * dphi * k.drag * i3, 1e-12 * q * dphi * i3);
          }
        }
      }
    }
  }
}

// 4. Added mass: pitch fixed at 90 deg (chord normal to the stroke), phi = A cos(2 pi n t) at t = 0:
// zero velocity, pure angular acceleration phi'' = -(2 pi n)^2 A. Per wing F = -rho pi/4 phi''
// int r c^2 dr n (Sane & Dickinson 2002), applied at the mid chord. Relative tolerance 1e-12.
TEST(QuasiSteadyClosedForm, AddedMassOfAcceleratingPlate) {
  const double A = 50 * deg, beta = -0.2;
  for (Planform p : {Planform::elliptic, Planform::rectangular}) {
    for (double x0 : {0.25, 0.5}) {
      const Insect in = test_insect(p, x0);
      WingAngles w;
      w.stroke = FourierSeries{0, {A}, {0}};
      w.pitch = FourierSeries{pi / 2, {}, {}};
      const Kinematics kin = kinematics(w, w, beta, 0.4);
      const Configuration config(in, kin);
      const double ddphi = -std::pow(2 * pi * kin.frequency_hz, 2) * A;
      // Normal of the right wing: R_P Rz(-A) Ry(90 deg) z = R_P Rz(-A) x; the left is its mirror image.
      const Vec3 n = rot_y(beta) * rot_z(-A) * Vec3::UnitX();
      const Vec3 es = rot_y(beta) * rot_z(-A) * Vec3::UnitY(), ec = -(rot_y(beta) * Vec3::UnitZ());
      const double k = -rho * pi / 4 * ddphi;
      const Vec3 f = k * planform_integral(p, 1, 2) * n;
      const WingPose pose = config.wing_pose(Side::right, 0.0);
      const Vec3 m = pose.hinge.cross(f) + k * planform_integral(p, 2, 2) * es.cross(n) +
                     k * (x0 - 0.5) * planform_integral(p, 1, 3) * ec.cross(n);
      for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
        const WrenchSample s = model(set).instantaneous(in, kin, 0.0, {});
        EXPECT_LE((s.right.force - f).norm(), 1e-12 * f.norm());
        EXPECT_LE((s.left.force - mirror_force(f)).norm(), 1e-12 * f.norm());
        EXPECT_LE((s.right.moment - m).norm(), 1e-12 * f.norm() * R);
        EXPECT_NEAR(s.power, 0.0, 1e-20);  // wings at rest relative to the body
        const WrenchSample off = model(set, true, false).instantaneous(in, kin, 0.0, {});
        EXPECT_LE(off.total().force.norm(), 1e-12 * f.norm());
      }
    }
  }
}

// 4b. The added-mass term's time derivative d(V_mid . n)/dt, including the body's rotation (inertial
// derivative in rotating axes), against central differences of V_mid(t) . n(t) built from the wing poses
// for general kinematics and body motion. Difference step 1e-6 T: tolerance 1e-6 of the force.
TEST(QuasiSteadyClosedForm, AddedMassRateMatchesFiniteDifferences) {
  const Insect in = test_insect(Planform::elliptic, 0.3);
  const Kinematics kin = kinematics(hover_wing(65, 0.1), hover_wing(50, -0.2));
  const Configuration config(in, kin);
  BodyMotion m;
  m.velocity = Vec3(0.4, -0.3, 0.2);
  m.rate = Vec3(6, -4, 9);
  const SpanQuadrature span = span_quadrature(in.wing, 40);
  const double h = 1e-6 * kin.period();
  for (double t : {0.1 * kin.period(), 0.37 * kin.period(), 0.8 * kin.period()}) {
    const WrenchSample on = model(CoefficientSet::robofly).instantaneous(in, kin, t, m);
    const WrenchSample off = model(CoefficientSet::robofly, true, false).instantaneous(in, kin, t, m);
    for (Side side : {Side::right, Side::left}) {
      auto w_mid = [&](double tt, std::size_t i) {
        const WingPose pose = config.wing_pose(side, tt);
        const Vec3 xi((in.wing.pitch_axis - 0.5) * span.c[i], span.r[i], 0);
        const Vec3 v = m.velocity + m.rate.cross(pose.position(xi)) + pose.velocity(xi);
        return v.dot(pose.axes.col(2));
      };
      const Vec3 n = config.wing_pose(side, t).axes.col(2);
      double sum = 0;
      for (std::size_t i = 0; i < span.r.size(); ++i)
        sum += span.c[i] * span.c[i] * span.w[i] * (w_mid(t + h, i) - w_mid(t - h, i)) / (2 * h);
      const Vec3 expected = -rho * pi / 4 * sum * n;
      const Vec3 got = side == Side::right ? Vec3(on.right.force - off.right.force) : Vec3(on.left.force - off.left.force);
      EXPECT_LE((got - expected).norm(), 1e-6 * expected.norm()) << "t " << t << " side " << int(side);
    }
  }
}

// 5. Rotational force: phi = A sin, alpha = alpha0 + B sin, at t = 0 (constant translation phi' and
// pitch rate alpha' = 2 pi n B). Circulation Gamma = C_rot c^2 alpha', C_rot = pi (3/4 - x0) (Sane &
// Dickinson 2002), Kutta-Joukowski force rho Gamma x U perpendicular to the flow: F_rot =
// C_rot rho phi' alpha' int r c^2 dr, upward for this horizontal stroke; a rotation that increases the
// incidence adds lift, in the downstroke (alpha = incidence) and in the upstroke (alpha = 180 deg - incidence).
// Added mass off. Relative tolerance 1e-12.
TEST(QuasiSteadyClosedForm, RotationalForceOfPitchingRevolvingWing) {
  const double A = 60 * deg, B = 20 * deg, incidence = 35 * deg;
  for (Planform p : {Planform::elliptic, Planform::rectangular}) {
    for (double x0 : {0.0, 0.25}) {
      const Insect in = test_insect(p, x0);
      for (double stroke_sign : {1.0, -1.0}) {          // downstroke, upstroke
        for (double incidence_rate_sign : {1.0, -1.0}) {  // pitching up or down relative to the flow
          const double alpha0 = stroke_sign > 0 ? incidence : pi - incidence;
          const double b = stroke_sign * incidence_rate_sign * B;  // alpha' sign that raises incidence
          WingAngles w;
          w.stroke = FourierSeries{0, {0}, {stroke_sign * A}};
          w.pitch = FourierSeries{alpha0, {0}, {b}};
          const Kinematics kin = kinematics(w, w, 0.0, 0.5);
          const double n2pi = 2 * pi * kin.frequency_hz;
          const double dphi = n2pi * A, dincidence = incidence_rate_sign * n2pi * B;  // magnitudes/signs
          const WrenchSample on = model(CoefficientSet::robofly, true, false).instantaneous(in, kin, 0.0, {});
          const WrenchSample off = model(CoefficientSet::robofly, false, false).instantaneous(in, kin, 0.0, {});
          // Perpendicular to the horizontal flow, on the lift side: up (-z) for either stroke.
          const Vec3 n_lift(0, 0, -1);
          const Vec3 f = pi * (0.75 - x0) * rho * dphi * dincidence * planform_integral(p, 1, 2) * n_lift;
          EXPECT_LE((on.right.force - off.right.force - f).norm(), 1e-12 * f.norm());
          EXPECT_LE((on.left.force - off.left.force - f).norm(), 1e-12 * f.norm());
          // Sign (Dickinson et al. 1999): raising the incidence increases lift (Fz more negative).
          EXPECT_EQ(on.total().force.z() < off.total().force.z(), incidence_rate_sign > 0);
        }
      }
    }
  }
}

// 6. Body motion coupling at hover-like kinematics (both coefficient sets): a forward speed u > 0 gives
// a mean X force opposing it (X_u < 0) and a sink w > 0 more upward force (Z_w < 0), as in every hover
// derivative table (Sun & Xiong 2005; Taha et al. 2014). Roll and yaw rates are damped (L_p < 0, N_r < 0:
// flapping counter-torque, Hedrick, Cheng & Deng 2009). A pitch rate changes the longitudinal loads and,
// by symmetry, no lateral ones; a roll rate changes longitudinal loads only at second order.
TEST(QuasiSteadyBodyMotion, DerivativesHavePhysicalSigns) {
  const Insect in = test_insect(Planform::elliptic, 0.25);
  const Kinematics kin = kinematics(hover_wing(), hover_wing(), 0.0, 0.6);
  const double U = 2 * kin.stroke_amplitude() * kin.frequency_hz * in.wing.radius_of_moment(2);
  const double du = 0.05 * U, dq = 0.05 * U / cbar;
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    const QuasiSteadyModel qs = model(set);
    auto mean = [&](Vec3 v, Vec3 w) { return qs.run(in, kin, BodyMotion{v, w}, {}).mean(); };
    const Wrench w0 = mean(Vec3::Zero(), Vec3::Zero());
    const double scale = std::abs(w0.force.z());
    ASSERT_GT(scale, 1e-4);
    EXPECT_LT(w0.force.z(), 0);  // hover kinematics support weight: force upward
    EXPECT_LT(mean(Vec3(du, 0, 0), Vec3::Zero()).force.x() - w0.force.x(), -1e-3 * scale);
    EXPECT_LT(mean(Vec3(0, 0, du), Vec3::Zero()).force.z() - w0.force.z(), -1e-3 * scale);
    const Wrench wp = mean(Vec3::Zero(), Vec3(dq, 0, 0)), wm = mean(Vec3::Zero(), Vec3(-dq, 0, 0));
    EXPECT_LT(wp.moment.x() - wm.moment.x(), -1e-3 * scale * R);
    EXPECT_LE(std::abs(wp.force.x() - wm.force.x()), 1e-12 * scale);  // dX/dp = 0 by symmetry
    EXPECT_LE(std::abs(wp.force.z() - wm.force.z()), 1e-12 * scale);
    EXPECT_LE(std::abs(wp.moment.y() - wm.moment.y()), 1e-12 * scale * R);
    EXPECT_LT(mean(Vec3::Zero(), Vec3(0, 0, dq)).moment.z() - w0.moment.z(), -1e-3 * scale * R);
    const Wrench wq = mean(Vec3::Zero(), Vec3(0, dq, 0));
    EXPECT_GT((wq.force - w0.force).norm() + (wq.moment - w0.moment).norm() / R, 1e-3 * scale);
    EXPECT_LE(std::abs(wq.force.y()), 1e-12 * scale);
    EXPECT_LE(std::abs(wq.moment.x()), 1e-12 * scale * R);
    EXPECT_LE(std::abs(wq.moment.z()), 1e-12 * scale * R);
    EXPECT_GT(qs.run(in, kin, {}, {}).mean_power(), 0);  // the wings work on the air
  }
}

// Body drag: -1/2 rho C_D A_i |V_i| V_i per anatomical axis at the body CoM; exact to 1e-12.
TEST(QuasiSteadyBodyMotion, BodyDragOnProjectedEllipses) {
  const double cd = 0.8, chi = 0.6, u = 0.7;
  const Insect in = test_insect(Planform::elliptic, 0.25, cd);
  const Kinematics kin = kinematics(hover_wing(), hover_wing(), 0.0, chi);
  const Configuration config(in, kin);
  const WrenchSample s = model(CoefficientSet::robofly).instantaneous(in, kin, 0.0, BodyMotion{Vec3(u, 0, 0), Vec3::Zero()});
  const double ax = pi / 4 * in.body.width * in.body.height, az = pi / 4 * in.body.length * in.body.width;
  const double va_x = std::cos(chi) * u, va_z = std::sin(chi) * u;  // S -> A: rot_y(chi)^T
  const Vec3 fa(-0.5 * rho * cd * ax * va_x * std::abs(va_x), 0, -0.5 * rho * cd * az * va_z * std::abs(va_z));
  const Vec3 f = rot_y(chi) * fa;
  EXPECT_LE((s.body.force - f).norm(), 1e-12 * f.norm());
  EXPECT_LE((s.body.moment - config.body_centre().cross(f)).norm(), 1e-12 * f.norm() * R);
  EXPECT_LT(s.body.force.x(), 0);
}

// Polynomial planforms: the constant polynomial is the rectangle, chord for chord, so the loads are identical (bit
// for bit: the same quadrature nodes, the same chords). A linear polynomial is a two-point table exactly: loads
// equal to round-off (1e-13 of the peak force; the chords differ only in the last bits).
TEST(QuasiSteadyPlanform, PolynomialReproducesRectangularAndLinearTable) {
  const Kinematics kin = kinematics(hover_wing(), hover_wing(70, 0.1));
  BodyMotion m;
  m.velocity = Vec3(0.2, -0.1, 0.3);
  m.rate = Vec3(1, 3, -2);
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    Insect rect = test_insect(Planform::rectangular, 0.3, 0.5), poly = rect;
    poly.wing.planform = Planform::polynomial;
    poly.wing.poly = {1.0};
    const WrenchHistory a = model(set).run(rect, kin, m, {}), b = model(set).run(poly, kin, m, {});
    ASSERT_EQ(a.samples.size(), b.samples.size());
    for (std::size_t k = 0; k < a.samples.size(); ++k) {
      const Wrench wa = a.samples[k].total(), wb = b.samples[k].total();
      for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(wa.force(i), wb.force(i));
        EXPECT_EQ(wa.moment(i), wb.moment(i));
      }
      EXPECT_EQ(a.samples[k].power, b.samples[k].power);
    }
    // Linear taper from 1.6 c_bar at the root to 0.4 c_bar at the tip, as a polynomial and as a table.
    Insect table = rect, linear = rect;
    table.wing.planform = Planform::tabulated;
    table.wing.table_r = {0.0, 1.0};
    table.wing.table_c = {1.6, 0.4};
    linear.wing.planform = Planform::polynomial;
    linear.wing.poly = {1.6, -1.2};
    const WrenchHistory t = model(set).run(table, kin, m, {}), l = model(set).run(linear, kin, m, {});
    double peak = 0;
    for (const auto& s : t.samples) peak = std::max(peak, s.total().force.norm());
    for (std::size_t k = 0; k < t.samples.size(); ++k) {
      EXPECT_LT((t.samples[k].total().force - l.samples[k].total().force).norm(), 1e-13 * peak);
      EXPECT_LT((t.samples[k].total().moment - l.samples[k].total().moment).norm(), 1e-13 * peak * R);
    }
  }
}

// Four wings: a hind pair identical to the fore pair and in phase with it carries exactly the fore pair's loads (the
// same strip sums repeated), so every wing load, the power and the load Jacobian double - to round-off (1e-14). The
// two-winged insect's wings carry the doubled mass, so that both have the same centre of mass O (with body rates the
// wing velocities depend on where O is).
TEST(QuasiSteadyFourWings, IdenticalInPhaseHindPairDoublesTheLoads) {
  Insect two = test_insect(Planform::elliptic, 0.3, 0);
  Insect four = two;
  four.hind_wing = two.wing;
  two.wing.mass *= 2;
  const Kinematics k2 = kinematics(hover_wing(), hover_wing(70, 0.1));
  Kinematics k4 = k2;
  k4.has_hind = true;
  k4.hind_right = k4.right;
  k4.hind_left = k4.left;
  BodyMotion m;
  m.velocity = Vec3(0.2, -0.1, 0.3);
  m.rate = Vec3(1, 3, -2);
  const Configuration c2(two, k2), c4(four, k4);
  ASSERT_LT((c2.reference_point() - c4.reference_point()).norm(), 1e-15);
  const SpanQuadrature s2 = span_quadrature(two, 40), s4 = span_quadrature(four, 40);
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    const QuasiSteadyModel qs = model(set);
    for (double tau : {0.0, 0.13, 0.37, 0.5, 0.81}) {
      const double t = tau * k2.period();
      const WrenchSample a = qs.loads(c2, s2, t, m), b = qs.loads(c4, s4, t, m);
      const double scale = a.total().force.norm() + a.right.force.norm();
      EXPECT_LT((b.total().force - 2 * a.total().force).norm(), 1e-14 * scale);
      EXPECT_LT((b.total().moment - 2 * a.total().moment).norm(), 1e-14 * scale * R);
      EXPECT_LT((b.right.force - 2 * a.right.force).norm(), 1e-14 * scale);
      EXPECT_NEAR(b.power, 2 * a.power, 1e-14 * std::abs(a.power));
      Eigen::Matrix<double, 6, 6> j2, j4;
      qs.loads_jacobian(c2, s2, t, m, j2);
      qs.loads_jacobian(c4, s4, t, m, j4);
      EXPECT_LT((j4 - 2 * j2).norm(), 1e-14 * j2.norm());
    }
  }
}

// A hind pair of its own (rectangular, shorter, behind, a quarter cycle ahead): its loads are those of a two-winged
// insect with that wing and those kinematics shifted by the phase, added to the fore pair's (no interaction in the
// quasi-steady model), with moments about the same point (the four-winged insect's O).
TEST(QuasiSteadyFourWings, HindPairAddsItsOwnLoads) {
  const Insect two = test_insect(Planform::elliptic, 0.3, 0);
  Insect four = two, hind_only = two;
  Wing hind = two.wing;
  hind.planform = Planform::rectangular;
  hind.length = 0.8 * R;
  hind.hinge = Vec3(-0.01, 0.004, -0.002);
  hind.pitch_axis = 0.2;
  four.hind_wing = hind;
  hind_only.wing = hind;
  const Kinematics k2 = kinematics(hover_wing(), hover_wing());
  Kinematics k4 = k2, kh = k2;
  k4.has_hind = true;
  k4.hind_right = k4.hind_left = hover_wing(50, 0.2);
  k4.hind_phase = 0.25;
  kh.right = kh.left = hover_wing(50, 0.2);
  BodyMotion m;
  m.velocity = Vec3(0.2, 0, 0.3);
  const QuasiSteadyModel qs = model(CoefficientSet::robofly, true, true);
  const Configuration c4(four, k4);
  // The same reference point for the parts: O of the four-winged insect.
  const Configuration c2(two, k2, c4.reference_point()), ch(hind_only, kh, c4.reference_point());
  const SpanQuadrature s4 = span_quadrature(four, 40), s2 = span_quadrature(two, 40), sh = span_quadrature(hind_only, 40);
  for (double tau : {0.05, 0.4, 0.7}) {
    const double t = tau * k4.period();
    const Wrench w4 = qs.loads(c4, s4, t, m).total(), w2 = qs.loads(c2, s2, t, m).total(),
                 wh = qs.loads(ch, sh, t + 0.25 * k4.period(), m).total();
    const double scale = w4.force.norm();
    EXPECT_LT((w4.force - w2.force - wh.force).norm(), 1e-13 * scale);
    EXPECT_LT((w4.moment - w2.moment - wh.moment).norm(), 1e-13 * scale * R);
  }
}

TEST(QuasiSteadyModel, NameAndSampling) {
  EXPECT_EQ(model(CoefficientSet::robofly).name(), "quasi-steady (robofly)");
  EXPECT_EQ(model(CoefficientSet::berman_wang).name(), "quasi-steady (berman-wang)");
  const Insect in = test_insect(Planform::elliptic);
  const Kinematics kin = kinematics(hover_wing(), hover_wing());
  const QuasiSteadyModel qs = model(CoefficientSet::robofly);
  EXPECT_EQ(qs.run(in, kin, {}, {}).samples.size(), 128u);
  const WrenchHistory h = qs.run(in, kin, {}, AeroRunOptions{1, 16});
  ASSERT_EQ(h.samples.size(), 16u);
  EXPECT_DOUBLE_EQ(h.samples[3].time, 3 * kin.period() / 16);
  const WrenchSample s = qs.instantaneous(in, kin, h.samples[3].time, {});
  EXPECT_EQ(s.total().force, h.samples[3].total().force);
  QuasiSteadyOptions no_elements;
  no_elements.rho = 1.2;
  no_elements.blade_elements = 0;
  EXPECT_THROW(QuasiSteadyModel{no_elements}, std::invalid_argument);
}

// The analytic loads_jacobian against central differences of `loads` at (t, m0): steps 1e-6 U and 1e-6 U / c
// (truncation ~1e-12, rounding ~1e-10 of the scale), agreement to 1e-7 of the force and moment scales; the wrench it
// returns is `loads`' total to round-off (1e-13).
void expect_jacobian_matches_differences(const QuasiSteadyModel& qs, const Configuration& config,
                                         const SpanQuadrature& span, double t, const BodyMotion& m0, double U,
                                         int k) {
  Eigen::Matrix<double, 6, 6> J;
  const Wrench w = qs.loads_jacobian(config, span, t, m0, J);
  const Wrench w_ref = qs.loads(config, span, t, m0).total();
  const double fs = std::max(w_ref.force.norm(), 1e-6), ms = fs * R;
  EXPECT_LT((w.force - w_ref.force).norm(), 1e-13 * fs) << k;
  EXPECT_LT((w.moment - w_ref.moment).norm(), 1e-13 * ms) << k;
  for (int j = 0; j < 6; ++j) {
    const double h = j < 3 ? 1e-6 * U : 1e-6 * U / cbar;
    BodyMotion p = m0, m = m0;
    (j < 3 ? p.velocity : p.rate)(j % 3) += h;
    (j < 3 ? m.velocity : m.rate)(j % 3) -= h;
    const Wrench wp = qs.loads(config, span, t, p).total(), wm = qs.loads(config, span, t, m).total();
    const double col = j < 3 ? U : U / cbar;  // d/dv and d/dOmega in units of the scales' rates
    EXPECT_LT(((wp.force - wm.force) / (2 * h) - J.col(j).head<3>()).norm() * col, 1e-7 * fs) << k << " " << j;
    EXPECT_LT(((wp.moment - wm.moment) / (2 * h) - J.col(j).tail<3>()).norm() * col, 1e-7 * ms) << k << " " << j;
  }
}

// loads_jacobian: the analytic d[F; M] / d[v; Omega] against central differences of `loads` (steps 1e-6 U and
// 1e-6 U / c; truncation ~1e-12, rounding ~1e-10 of the scale) at phases through the stroke and its reversals,
// for both coefficient sets, with a forward-climbing, pitching and rolling body and body drag on: agreement to
// 1e-7 of the force and moment scales. The wrench it returns is `loads`' total to round-off.
TEST(QuasiSteadyBodyMotion, AnalyticJacobianMatchesFiniteDifferences) {
  const Insect in = test_insect(Planform::elliptic, 0.3, 0.6);
  const Kinematics kin = kinematics(hover_wing(60, 0.1), hover_wing(55, -0.2), 0.1, 0.6);
  const double U = 2 * kin.stroke_amplitude() * kin.frequency_hz * in.wing.radius_of_moment(2);
  const Configuration config(in, kin);
  for (CoefficientSet set : {CoefficientSet::robofly, CoefficientSet::berman_wang}) {
    const QuasiSteadyModel qs = model(set);
    const SpanQuadrature span = span_quadrature(in.wing, qs.options().blade_elements);
    const BodyMotion m0{Vec3(0.2 * U, 0.05 * U, -0.1 * U), Vec3(0.1, -0.3, 0.2) * U / cbar};
    for (int k = 0; k < 16; ++k)
      expect_jacobian_matches_differences(qs, config, span, kin.period() * (k + 0.37) / 16, m0, U, k);
  }
}

// [abdomen] drag (an ellipsoid of the given diameters centred at the abdomen CoM, its axes turned by the relative
// pitch eta): by hand at phases through a flexing abdomen's cycle, with a climbing, pitching body. The centre moves at
// v + Omega x p + eta' e_y x (R c); in abdomen axes f_i = -rho C_D A_i |v_i| v_i / 2 on the projected ellipse areas;
// F = R f about O with the lever p. The rotation R = R_SA R_y(eta) written out (R_y turns x towards -z). The
// quasi-steady wrench with the drag less the one without is the hand value to 1e-12 of the wrenches; the analytic Jacobian
// agrees with central differences of the loads (as the test above, 1e-7 of the scales).
TEST(QuasiSteadyBodyMotion, AbdomenDragByHandAndItsJacobian) {
  Insect in = test_insect(Planform::elliptic);
  Abdomen a;
  a.mass = 0.8e-3;
  a.joint = Vec3(-0.006, 0, 0.001);
  a.centre = Vec3(-0.012, 0, 0.002);
  a.inertia_cg = Vec3(1e-8, 1.5e-7, 1.5e-7).asDiagonal();
  a.pitch = fourier(10, {15}, {5});
  in.abdomen = a;
  Insect dragged = in;
  dragged.abdomen->drag_coefficient = 1.3;
  dragged.abdomen->diameters = Vec3(0.024, 0.010, 0.009);
  const Kinematics kin = kinematics(hover_wing(60, 0.1), hover_wing(60, 0.1), 0.1, 0.6);
  const double U = 2 * kin.stroke_amplitude() * kin.frequency_hz * in.wing.radius_of_moment(2);
  const Configuration plain(in, kin), config(dragged, kin);
  const QuasiSteadyModel qs = model(CoefficientSet::robofly);
  const SpanQuadrature span = span_quadrature(in.wing, qs.options().blade_elements);
  const BodyMotion m0{Vec3(0.2 * U, 0.05 * U, -0.1 * U), Vec3(0.1, -0.3, 0.2) * U / cbar};
  const double rho_ = qs.options().rho;
  const Mat3 r_sa = config.anatomical_to_stability();
  for (int k = 0; k < 8; ++k) {
    const double t = kin.period() * (k + 0.37) / 8, tau = t * kin.frequency_hz, w = 2 * pi * tau;
    const double eta = (10 + 15 * std::cos(w) + 5 * std::sin(w)) * deg;
    const double eta_dot = (-15 * std::sin(w) + 5 * std::cos(w)) * deg * 2 * pi * kin.frequency_hz;
    Mat3 Ry;
    Ry << std::cos(eta), 0, std::sin(eta), 0, 1, 0, -std::sin(eta), 0, std::cos(eta);
    const Mat3 Rab = r_sa * Ry;
    const Vec3 p = config.body_centre() + r_sa * a.joint + Rab * a.centre;
    const Vec3 v = m0.velocity + m0.rate.cross(p) + Vec3(0, eta_dot, 0).cross(Rab * a.centre);
    const Vec3 va = Rab.transpose() * v;
    const Vec3 d = dragged.abdomen->diameters;
    const Vec3 area(pi / 4 * d.y() * d.z(), pi / 4 * d.x() * d.z(), pi / 4 * d.x() * d.y());
    Vec3 fa;
    for (int i = 0; i < 3; ++i) fa(i) = -0.5 * rho_ * 1.3 * area(i) * std::abs(va(i)) * va(i);
    const Vec3 F = Rab * fa, M = p.cross(F);
    const Wrench with = qs.loads(config, span, t, m0).total(), without = qs.loads(plain, span, t, m0).total();
    // The difference of two wrenches carries their rounding: 1e-12 of the drag plus the whole wrench.
    EXPECT_LT((with.force - without.force - F).norm(), 1e-12 * (F.norm() + with.force.norm())) << k;
    EXPECT_LT((with.moment - without.moment - M).norm(), 1e-12 * (M.norm() + with.moment.norm())) << k;
    EXPECT_GT(F.norm(), 1e-6) << k;  // N: at least 3e-4 of the wings' force at this body speed (measured)
    expect_jacobian_matches_differences(qs, config, span, t, m0, U, k);
  }
}

}  // namespace
}  // namespace flapstab
