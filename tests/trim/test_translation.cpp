// The translation-only model (trim/translation.hpp): the prescribed attitude's rates, the blade velocities and the
// inertial terms against hand calculations, and its Floquet exponents against the free model's in the limit of an
// infinitely stiff attitude (large body inertia).
#include <gtest/gtest.h>

#include <cmath>

#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "common/case_text.hpp"
#include "common/robofly.hpp"
#include "common/test_insect.hpp"
#include "core/rotation.hpp"
#include "trim/translation.hpp"

namespace flapstab {
namespace {

// Pitch alone: q = theta', q' = theta'' (p = r = 0) for theta = A sin(2 pi n t) + B cos(4 pi n t), by hand; and with
// roll and yaw as well, skew(w) = R^T dR/dt and w' against sixth-order central differences of the rotation (1e-7).
TEST(Translation, PrescribedRatesByHand) {
  const double n = 25, A = 6 * deg, B = 2 * deg, t = 0.0123, w1 = 2 * pi * n;
  BodyMotionSettings b;
  b.pitch = FourierSeries{0.0, {0.0, B}, {A, 0.0}};
  const PrescribedAttitude a = prescribed_attitude(b, n, t);
  EXPECT_NEAR(a.theta, A * std::sin(w1 * t) + B * std::cos(2 * w1 * t), 1e-15);
  EXPECT_NEAR(a.rates.y(), A * w1 * std::cos(w1 * t) - 2 * B * w1 * std::sin(2 * w1 * t), 1e-12);
  EXPECT_NEAR(a.rates_dot.y(), -A * w1 * w1 * std::sin(w1 * t) - 4 * B * w1 * w1 * std::cos(2 * w1 * t), 1e-9);
  EXPECT_EQ(a.rates.x(), 0.0);
  EXPECT_EQ(a.rates.z(), 0.0);
  b.roll = FourierSeries{3 * deg, {4 * deg}, {-5 * deg}};
  b.yaw = FourierSeries{-2 * deg, {1 * deg, 2 * deg}, {7 * deg, 0.0}};
  const PrescribedAttitude g = prescribed_attitude(b, n, t);
  auto R = [&](double s) {
    const PrescribedAttitude x = prescribed_attitude(b, n, s);
    return euler321(x.phi, x.theta, x.psi);
  };
  const double h = 1e-5;
  auto d6 = [&](auto f) {  // sixth-order central difference
    using T = decltype(f(t));
    const T d = (-f(t - 3 * h) + 9 * f(t - 2 * h) - 45 * f(t - h) + 45 * f(t + h) - 9 * f(t + 2 * h) + f(t + 3 * h)) /
                (60 * h);
    return d;
  };
  const Mat3 W = R(t).transpose() * d6([&](double s) -> Mat3 { return R(s); });
  EXPECT_LT((Vec3(W(2, 1), W(0, 2), W(1, 0)) - g.rates).norm(), 1e-7 * g.rates.norm());
  const Vec3 wd = d6([&](double s) -> Vec3 { return prescribed_attitude(b, n, s).rates; });
  EXPECT_LT((wd - g.rates_dot).norm(), 1e-7 * g.rates_dot.norm());
}

// Blade velocities: still wings (stroke 0, pitch 60 deg, rectangular, no rotational or added-mass terms), the body
// rolling at the prescribed p = phi'(t). A blade element of the right wing at span r moves at p (h_y + r) along z
// (the velocity along the span is dropped), at 90 - 60 = 30 deg to the chord, so the right wing's force is
// (1/2) rho p^2 C(30 deg) c int_0^R (h_y + r)^2 dr: its z part is -drag (p > 0), its size sqrt(C_L^2 + C_D^2) times
// that (Robofly fits of Dickinson et al. 1999; 1e-5: the model's coefficient fit).
TEST(Translation, BladeVelocitiesFromThePrescribedRollRate) {
  Insect ins = testing::test_insect();
  ins.wing.planform = Planform::rectangular;
  Kinematics k = testing::harmonic_kinematics(25, 0, 30, 0, 0);
  k.right.stroke = FourierSeries{0.0, {}, {}};
  k.right.pitch = FourierSeries{60 * deg, {}, {}};
  k.right.deviation = FourierSeries{};
  k.left = k.right;
  QuasiSteadyOptions qo;
  qo.rotational = false;
  qo.added_mass = false;
  qo.blade_elements = 40;
  const QuasiSteadyModel model(qo);
  BodyMotionSettings b;
  b.roll = FourierSeries{0.0, {0.0}, {10 * deg}};  // phi = 10 deg sin(2 pi n t)
  const double t = 0.004, p = 10 * deg * 2 * pi * 25 * std::cos(2 * pi * 25 * t);
  ASSERT_GT(p, 0);
  const BodyStateVector x = translation_body_state(b, k.frequency_hz, t, TranslationState::Zero());
  EXPECT_NEAR(x(6), p, 1e-12);
  const WrenchSample s = model.instantaneous(ins, k, t, body_motion(x));
  const double hy = ins.wing.hinge.y(), R = ins.wing.length;
  const double span = ins.wing.mean_chord * (std::pow(hy + R, 3) - std::pow(hy, 3)) / 3;
  const double q = 0.5 * qo.rho * p * p * span;
  const double cl = robofly::translational_cl(30), cd = robofly::translational_cd(30);
  std::printf("    right wing force %.6e N (hand %.6e), z %.6e (hand %.6e)\n", s.right.force.norm(),
              q * std::hypot(cl, cd), s.right.force.z(), -q * cd);
  EXPECT_NEAR(s.right.force.z(), -q * cd, 1e-5 * q * cd);
  EXPECT_NEAR(s.right.force.norm(), q * std::hypot(cl, cd), 1e-5 * q * std::hypot(cl, cd));
  EXPECT_NEAR(s.right.force.y(), 0.0, 1e-12 * q);
}

// Inertial terms: flapping wings, the body pitched by a prescribed series. By hand, with w = (0, theta', 0),
// w' = (0, theta'', 0), c, c' and sum m r'' of the mass state, P = m v + w x c + c' and g_B = g (-sin theta, 0,
// cos theta): m v' = F + m g_B - w x P - w' x c - w x c' - sum m r'', x' = R v (1e-12 relative).
TEST(Translation, InertialTermsByHand) {
  const Case c = load_case(testing::write_temp("translation_hand.toml", testing::valid_case_text()));
  const auto model = make_aero_model(c);
  const InstantaneousAero aero(*model, c.insect, c.kinematics);
  BodyMotionSettings b;
  b.pitch = FourierSeries{4 * deg, {8 * deg}, {-3 * deg}};
  const double n = c.kinematics.frequency_hz;
  TranslationState y;
  y << 0.01, -0.02, 0.03, 0.2, 0.05, -0.1;
  for (double t : {0.0, 0.0071, 0.023}) {
    const SeriesValue th = b.pitch.eval(t * n);
    const Vec3 w(0, th.df * n, 0), wd(0, th.ddf * n * n, 0), v = y.tail<3>();
    const MassState ms = aero.configuration().mass_state(t);
    double m = 0;
    Vec3 cc = Vec3::Zero(), cd = Vec3::Zero(), sr = Vec3::Zero();
    for (const PartMass* part : ms.parts()) {
      m += part->mass;
      cc += part->mass * part->r;
      cd += part->mass * part->r_dot;
      sr += part->mass * part->r_ddot;
    }
    const Vec3 F = aero(t, BodyMotion{v, w}).force;
    const double g = c.insect.gravity;
    const Vec3 gB(-g * std::sin(th.f), 0, g * std::cos(th.f));
    const Vec3 P = m * v + w.cross(cc) + cd;
    const Vec3 acc = (F + m * gB - w.cross(P) - wd.cross(cc) - w.cross(cd) - sr) / m;
    const TranslationState d = translation_derivative(aero, b, t, y);
    EXPECT_LT((d.tail<3>() - acc).norm(), 1e-12 * acc.norm()) << t;
    EXPECT_LT((d.head<3>() - euler321(0, th.f, 0) * v).norm(), 1e-15) << t;
    // The prescribed motion matters: without it the acceleration differs.
    EXPECT_GT((translation_derivative(aero, BodyMotionSettings{}, t, y).tail<3>() - acc).norm(), 1e-3 * acc.norm());
  }
}

// Multipliers of the free model's [u, w, q, theta] and [v, p, r, phi] monodromy blocks nearest to each of the
// translation-only model's, at body inertia k x the hawkmoth-like test insect's.
struct LimitRun {
  std::vector<std::complex<double>> translation, free;
  double parameter_difference = 0;
};

LimitRun large_inertia_run(double k) {
  Case c = load_case(testing::write_temp("translation_limit.toml", testing::valid_case_text()));
  c.insect.body.inertia *= k;
  const auto model = make_aero_model(c);
  const TrimResult avg = trim_hover(c, *model);
  const CyclicTrimResult free = cyclic_trim(c, *model, avg);
  EXPECT_TRUE(free.converged) << free.message;
  c.body_motion.present = true;
  c.body_motion.trim_parameters = {"stroke_amplitude_deg", "pitch_mean_deg"};
  const TranslationTrimResult tr = translation_cyclic_trim(c, *model, free.kinematics);
  EXPECT_TRUE(tr.converged) << tr.message;
  LimitRun out;
  out.parameter_difference = std::max(std::abs(tr.parameters[0].value - free.parameters[0].value),
                                      std::abs(tr.parameters[1].value - free.parameters[2].value));
  const Eigen::VectorXcd mt = tr.monodromy.eigenvalues();
  for (Eigen::Index i = 0; i < 3; ++i) out.translation.push_back(mt(i));
  Eigen::Matrix4d lon, lat;
  const int il[4] = {0, 2, 4, 7}, ia[4] = {1, 3, 5, 6};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      lon(i, j) = free.monodromy(il[i], il[j]);
      lat(i, j) = free.monodromy(ia[i], ia[j]);
    }
  const Eigen::Vector4cd ml = lon.eigenvalues(), ma = lat.eigenvalues();
  for (const auto& mu : out.translation) {
    std::complex<double> best = 1e300;
    for (int i = 0; i < 4; ++i)
      for (const auto& cand : {ml(i), ma(i)})
        if (std::abs(cand - mu) < std::abs(best - mu)) best = cand;
    out.free.push_back(best);
  }
  return out;
}

// Translation-only Floquet exponents = the free model's with an infinitely stiff attitude. With the body inertia
// scaled by k the free model's attitude modes slow down as k^(-1/3) (gravity couples pitch to surge: s^3 ~ g M_u / I)
// and, once they are much slower than the translational modes (multipliers 0.87 to 0.94 per wingbeat here, reached
// for k >~ 1e6), the translational multipliers differ from the translation-only ones by O(1/k). Shown: the largest
// difference in log(mu) per wingbeat falls as 1/k (by 50 to 200 from k = 1e7 to 1e9; measured 4.3e-5 -> 4.3e-7) and
// is below 1e-6 at k = 1e9, where the two trims' shared parameters agree to 1e-7 deg (measured 1e-8, the trims'
// tolerance).
TEST(Translation, FloquetExponentsEqualTheFreeModelsInTheLargeInertiaLimit) {
  double diff[2] = {0, 0};
  const double ks[2] = {1e7, 1e9};
  for (int r = 0; r < 2; ++r) {
    const LimitRun run = large_inertia_run(ks[r]);
    for (std::size_t i = 0; i < run.translation.size(); ++i)
      diff[r] = std::max(diff[r], std::abs(std::log(run.translation[i]) - std::log(run.free[i])));
    std::printf("    k = %.0e: largest |log mu_translation - log mu_free| = %.3e, parameters differ by %.3e deg\n", ks[r],
                diff[r], run.parameter_difference);
    if (r == 1) {
      EXPECT_LT(run.parameter_difference, 1e-7);
    }
  }
  EXPECT_LT(diff[1], 1e-6);
  EXPECT_GT(diff[0], 50 * diff[1]);
  EXPECT_LT(diff[0], 200 * diff[1]);
}

}  // namespace
}  // namespace flapstab
