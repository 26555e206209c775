// Free flight: conservation without loads, exact free fall, open-loop growth at the Floquet rate, the
// translation-only system's Floquet exponents, and bad controller input.
#include <gtest/gtest.h>

#include <cmath>

#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "common/expect_error.hpp"
#include "core/rotation.hpp"
#include "flight/free_flight.hpp"
#include "stability/floquet.hpp"
#include "trim/cyclic.hpp"

namespace flapstab {
namespace {

struct Hover {
  Case c;
  std::unique_ptr<AeroModel> model;
  TrimResult averaged;
  CyclicTrimResult cyclic;
  ReferenceQuantities ref;
  std::vector<BodyStateVector> orbit;
};

// The shipped hawkmoth case, trimmed (averaged, then cyclic) once for all tests.
const Hover& hawkmoth() {
  static const Hover h = [] {
    Hover x;
    x.c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml");
    x.model = make_aero_model(x.c);
    x.averaged = trim_hover(x.c, *x.model);
    x.cyclic = cyclic_trim(x.c, *x.model, x.averaged);
    x.ref = reference_quantities(x.c.insect, x.cyclic.kinematics, x.c.fluid);
    const InstantaneousAero aero(*x.model, x.c.insect, x.cyclic.kinematics);
    x.orbit = periodic_orbit(aero, x.cyclic.initial_state, 64);
    return x;
  }();
  return h;
}

// Without aerodynamics and gravity the linear and angular momentum of body plus flapping wings are conserved
// (core/eom.hpp's system_momenta): to 1e-9 of the wings' momentum scale m_w 2 pi n R over 100 wingbeats. The wings
// flap in stroke only (feathering held at 90 deg): with the hawkmoth's full kinematics the wings' non-reciprocal
// motion rotates the body steadily (it passes 80 deg of pitch within 10 wingbeats in vacuum), and the Euler angles
// cannot follow it through 90 deg; a one-angle (reciprocal) stroke gives no net rotation.
TEST(FreeFlight, MomentaConservedWithoutLoadsOver100Wingbeats) {
  const Hover& h = hawkmoth();
  Kinematics k = h.cyclic.kinematics;
  k.right.pitch = FourierSeries{90 * deg, {}, {}};
  k.left.pitch = k.right.pitch;
  const FlightDynamics dyn(*h.model, h.c.insect, k, {}, DofSet::six_dof, 0.0, false);
  BodyStateVector x0 = BodyStateVector::Zero();
  x0.segment<3>(3) = Vec3(0.1, -0.05, 0.02);
  x0.segment<3>(6) = Vec3(0.02, -0.05, 0.01);
  x0.segment<3>(9) = Vec3(0.1, 0.2, -0.3);
  FlightOptions o;
  o.wingbeats = 100;
  o.samples_per_wingbeat = 1;
  o.rtol = 1e-12;
  const ReferenceOrbit still{[&](double) { return x0; }, x0};
  const FlightResult r = simulate_flight(dyn, ControllerSpec{}, x0, still, h.ref, o);
  ASSERT_TRUE(r.completed) << r.stop_reason;
  ASSERT_EQ(r.samples.size(), 101u);
  Vec3 P0, H0, P1, H1;
  system_momenta(dyn.configuration(), 0.0, x0, P0, H0);
  system_momenta(dyn.configuration(), 100 * k.period(), r.samples.back().x, P1, H1);
  const Insect& ins = h.c.insect;
  const double p_scale = ins.wing.mass * 2 * M_PI * k.frequency_hz * ins.wing.length;
  EXPECT_LT((P1 - P0).norm(), 1e-9 * std::max(p_scale, P0.norm()));
  EXPECT_LT((H1 - H0).norm(), 1e-9 * std::max(p_scale * ins.wing.length, H0.norm()));
  EXPECT_GT((r.samples.back().x.segment<3>(6) - x0.segment<3>(6)).norm(), 1e-3);  // the body did move
}

// Free fall without aerodynamics: the system's centre of mass falls as z0 + g t^2 / 2 exactly, whatever the
// wings do (to 1e-9 of the distance fallen after 5 wingbeats).
TEST(FreeFlight, FreeFallOfTheCentreOfMassIsExact) {
  const Hover& h = hawkmoth();
  const double g = 9.80665;
  const FlightDynamics dyn(*h.model, h.c.insect, h.cyclic.kinematics, {}, DofSet::six_dof, g, false);
  const BodyStateVector x0 = h.cyclic.initial_state;
  FlightOptions o;
  o.wingbeats = 5;
  o.samples_per_wingbeat = 4;
  o.rtol = 1e-12;
  const ReferenceOrbit still{[&](double) { return x0; }, x0};
  const FlightResult r = simulate_flight(dyn, ControllerSpec{}, x0, still, h.ref, o);
  const double m = h.c.insect.total_mass();
  auto com = [&](const FlightSample& s) {
    const MassState ms = dyn.configuration().mass_state(s.t);
    return Vec3(s.x.head<3>() + euler321(s.x(9), s.x(10), s.x(11)) * (ms.first_moment() / m));
  };
  Vec3 P0, H0;
  system_momenta(dyn.configuration(), 0.0, x0, P0, H0);
  const Vec3 v_com0 = P0 / m, c0 = com(r.samples.front());
  for (const FlightSample& s : r.samples) {
    const Vec3 expected = c0 + v_com0 * s.t + Vec3(0, 0, 0.5 * g * s.t * s.t);
    const double fallen = 0.5 * g * s.t * s.t;
    EXPECT_LT((com(s) - expected).norm(), 1e-9 * std::max(fallen, 1e-6)) << "t = " << s.t;
  }
}

// Growth of a small perturbation along the most unstable Floquet mode of a subsystem, measured in the nonlinear
// simulation by the mode's own coordinate at whole wingbeats, against log|mu| per wingbeat: within 2 % over 6
// wingbeats (the tolerance). The monodromy is the cyclic trim's CVODES flow sensitivity.
void expect_floquet_growth(const std::vector<int>& states, DofSet dofs, const char* name) {
  const Hover& h = hawkmoth();
  const FlightDynamics dyn(*h.model, h.c.insect, h.cyclic.kinematics, {}, dofs);
  Eigen::MatrixXd M(4, 4);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) M(i, j) = h.cyclic.monodromy(states[std::size_t(i)], states[std::size_t(j)]);
  const Eigen::EigenSolver<Eigen::MatrixXd> es(M);
  int k = 0;
  for (int i = 1; i < 4; ++i)
    if (std::abs(es.eigenvalues()(i)) > std::abs(es.eigenvalues()(k))) k = i;
  const std::complex<double> mu = es.eigenvalues()(k);
  ASSERT_GT(std::abs(mu), 1.0) << name << ": the hawkmoth's " << name << " hover should have an unstable mode";
  const Eigen::MatrixXcd V = es.eigenvectors(), Vinv = V.inverse();
  const Eigen::VectorXd scale = nondimensional_state_scale(
      states.size() == 4 && states[0] == 0 ? std::vector<std::string>{"u", "w", "q", "theta"}
                                           : std::vector<std::string>{"v", "p", "r", "phi"},
      h.ref);
  // Perturbation: 1e-5 (non-dimensional) along Re v.
  Eigen::VectorXd dv = V.col(k).real();
  dv /= (scale.asDiagonal() * dv).cwiseAbs().maxCoeff();
  dv *= 1e-5;
  BodyStateVector x0 = h.cyclic.initial_state;
  for (int i = 0; i < 4; ++i) x0(linear_state_index[states[std::size_t(i)]]) += dv(i);
  FlightOptions o;
  o.wingbeats = 6;
  o.samples_per_wingbeat = 1;
  o.rtol = 1e-11;
  const ReferenceOrbit ref = reference_orbit(h.orbit, h.cyclic.period);
  const FlightResult r = simulate_flight(dyn, ControllerSpec{}, x0, ref, h.ref, o);
  ASSERT_EQ(r.samples.size(), 7u);
  auto modal = [&](const BodyStateVector& x) {
    Eigen::VectorXcd d(4);
    for (int i = 0; i < 4; ++i)
      d(i) = x(linear_state_index[states[std::size_t(i)]]) - h.cyclic.initial_state(linear_state_index[states[std::size_t(i)]]);
    return (Vinv * d)(k);
  };
  const double c0 = std::abs(modal(r.samples[0].x)), c6 = std::abs(modal(r.samples[6].x));
  const double simulated = std::log(c6 / c0) / 6, floquet = std::log(std::abs(mu));
  EXPECT_NEAR(simulated, floquet, 0.02 * std::abs(floquet)) << name << ": |mu| = " << std::abs(mu);
  ::testing::Test::RecordProperty(std::string(name) + "_growth_per_wingbeat_simulated", std::to_string(simulated));
  ::testing::Test::RecordProperty(std::string(name) + "_growth_per_wingbeat_floquet", std::to_string(floquet));
}

TEST(FreeFlight, LongitudinalPerturbationGrowsAtTheFloquetRate) {
  expect_floquet_growth({0, 2, 4, 7}, DofSet::longitudinal, "longitudinal");
}

TEST(FreeFlight, LateralPerturbationGrowsAtTheFloquetRateIn6Dof) {
  expect_floquet_growth({1, 3, 5, 6}, DofSet::six_dof, "lateral");
}

// Translation only (attitude held): the periodic velocity orbit by Newton on the one-wingbeat map, its monodromy
// by central differences of the nonlinear simulation, against the monodromy of the linearised constrained system
// (A(t) = d f / d[u v w] by central differences of the right-hand side at 64 phases, CVODE): multipliers agree to
// 1e-5 (the spline through A(t) dominates: 64 phases gave 3e-5 to 7e-5, 256 phases less than 1e-5).
TEST(FreeFlight, TranslationOnlyFloquetMultipliersFromSimulationAndLinearisation) {
  const Hover& h = hawkmoth();
  const FlightDynamics dyn(*h.model, h.c.insect, h.cyclic.kinematics, {}, DofSet::translation);
  const double T = h.cyclic.period;
  FlightOptions o;
  o.wingbeats = 1;
  o.samples_per_wingbeat = 1;
  o.rtol = 1e-12;
  const ReferenceOrbit still{[](double) { return BodyStateVector::Zero().eval(); }, BodyStateVector::Zero()};
  auto period_map = [&](const Eigen::Vector3d& v) {
    BodyStateVector x = BodyStateVector::Zero();
    x.segment<3>(3) = v;
    return Eigen::Vector3d(simulate_flight(dyn, ControllerSpec{}, x, still, h.ref, o).samples.back().x.segment<3>(3));
  };
  const double hv = 1e-6 * h.ref.U;
  auto jacobian = [&](const Eigen::Vector3d& v) {
    Eigen::Matrix3d J;
    for (int j = 0; j < 3; ++j) {
      Eigen::Vector3d p = v, m = v;
      p(j) += hv;
      m(j) -= hv;
      J.col(j) = (period_map(p) - period_map(m)) / (2 * hv);
    }
    return J;
  };
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (int it = 0; it < 8; ++it) {
    const Eigen::Vector3d r = period_map(v) - v;
    if (r.norm() < 1e-12 * h.ref.U) break;
    v -= (jacobian(v) - Eigen::Matrix3d::Identity()).partialPivLu().solve(r);
  }
  ASSERT_LT((period_map(v) - v).norm(), 1e-10 * h.ref.U);
  const Eigen::Matrix3d M_sim = jacobian(v);
  // Linearised: orbit samples, A(t_k) by central differences of the constrained right-hand side.
  const int N = 256;
  BodyStateVector xv = BodyStateVector::Zero();
  xv.segment<3>(3) = v;
  FlightOptions on = o;
  on.samples_per_wingbeat = N;
  const FlightResult orbit = simulate_flight(dyn, ControllerSpec{}, xv, still, h.ref, on);
  std::vector<Eigen::MatrixXd> A;
  for (int k = 0; k < N; ++k) {
    const FlightSample& s = orbit.samples[std::size_t(k)];
    Eigen::MatrixXd Ak(3, 3);
    for (int j = 0; j < 3; ++j) {
      BodyStateVector p = s.x, m = s.x;
      p(3 + j) += hv;
      m(3 + j) -= hv;
      Ak.col(j) = (dyn.derivative(s.t, p, {}).dx - dyn.derivative(s.t, m, {}).dx).segment<3>(3) / (2 * hv);
    }
    A.push_back(Ak);
  }
  const PeriodicMatrixSpline As(T, A);
  const MonodromyResult lin = monodromy([&](double t) { return As(t); }, 3, T);
  Eigen::VectorXcd mu_sim = Eigen::EigenSolver<Eigen::MatrixXd>(M_sim).eigenvalues();
  Eigen::VectorXcd mu_lin = Eigen::EigenSolver<Eigen::MatrixXd>(lin.monodromy).eigenvalues();
  auto sorted = [](Eigen::VectorXcd z) {
    std::vector<std::complex<double>> s(z.data(), z.data() + z.size());
    std::sort(s.begin(), s.end(), [](auto a, auto b) { return a.real() != b.real() ? a.real() < b.real() : a.imag() < b.imag(); });
    return s;
  };
  const auto a = sorted(mu_sim), b = sorted(mu_lin);
  for (int i = 0; i < 3; ++i) EXPECT_LT(std::abs(a[std::size_t(i)] - b[std::size_t(i)]), 1e-5) << "multiplier " << i;
  // Held attitude: translation alone is stable for the hovering hawkmoth (drag damps u, v, w).
  for (const auto& m : a) EXPECT_LT(std::abs(m), 1.0);
}

// Controller bad input: every field is named.
TEST(Controller, BadInputNamesTheKey) {
  PitchControllerSettings s;
  s.pitch_gain = 1;
  ControllerSpec c = pitch_controller(s, -15);
  c.terms[0].latency_s = -0.01;
  testing::expect_input_error([&] { validate_controller(c, "case.toml", "control.feedback"); },
                              "control.feedback[0].latency_s", "case.toml");
  c = pitch_controller(s, -15);
  c.terms[1].gain = std::nan("");
  testing::expect_input_error([&] { validate_controller(c, "f", "control.feedback"); }, "control.feedback[1].gain");
  c = pitch_controller(s, -15);
  c.terms[0].state = "alpha";
  testing::expect_input_error([&] { validate_controller(c, "f", "control.feedback"); }, "control.feedback[0].state");
  c = pitch_controller(s, -15);
  c.terms[0].actuator = "wing_twist_deg";
  testing::expect_input_error([&] { validate_controller(c, "f", "control.feedback"); },
                              "control.feedback[0].actuator");
  testing::expect_input_error([] { parse_dof_set("5dof", "f", "flight.dof"); }, "flight.dof");
}

// The growth estimates on a synthetic deviation: theta - theta_ref = a exp(g t / T) + b sin(2 pi t / T), 40 samples per
// wingbeat over 8 wingbeats. The wingbeat means drop the rocking term (a whole period of uniform samples): mean k =
// a exp(g k) (1/40) sum_j exp(g j / 40), so their log-slope is g exactly (1e-10); the largest |deviation| per
// wingbeat is dominated by the rocking and its slope is not g.
TEST(FreeFlight, WingbeatMeanDeviationRemovesTheRocking) {
  const double T = 0.04, a = 1e-3, g = 0.3, b = 0.05;
  FlightResult r;
  for (int n = 0; n <= 8 * 40; ++n) {
    FlightSample s;
    s.t = n * T / 40;
    s.x = BodyStateVector::Zero();
    s.x(10) = a * std::exp(g * s.t / T) + b * std::sin(2 * pi * s.t / T);
    r.samples.push_back(s);
  }
  const ReferenceOrbit zero{[](double) { return BodyStateVector::Zero().eval(); }, BodyStateVector::Zero()};
  ReferenceQuantities ref;
  ref.c = 0.02;
  ref.U = 5;
  const GrowthEstimate e = wingbeat_growth(r, zero, ref, T, {10}, 2);
  ASSERT_EQ(e.mean_deviation.size(), 8u);
  double c = 0;
  for (int j = 0; j < 40; ++j) c += std::exp(g * j / 40.0) / 40;
  for (int k = 0; k < 8; ++k) EXPECT_NEAR(e.mean_deviation[std::size_t(k)], a * std::exp(g * k) * c, 1e-12) << k;
  EXPECT_NEAR(e.mean_per_wingbeat, g, 1e-10);
  EXPECT_GT(std::abs(e.per_wingbeat - g), 0.1);  // the rocking hides the growth in the largest deviation
}

// The growth fit's window stays inside the flight. With a first wingbeat given (the library's callers may; flapstab's
// commands take the default, the second half) a flight of one wingbeat used to get first = -1, and the fit read
// past the start of its deviations and returned a number. Now the fit is empty (first = last = 0, no growth). On
// four wingbeats of a deviation growing as exp(0.3 t / T) the fit over wingbeats 2-3 of the wingbeat means (the same
// sample phases in each) gives 0.3 per wingbeat.
TEST(FreeFlight, GrowthFitWindowStaysInsideTheFlight) {
  const double T = 0.04;
  ReferenceQuantities ref;
  ref.U = 2;
  ref.c = 0.02;
  ReferenceOrbit orbit;
  orbit.state = [](double) { return BodyStateVector::Zero(); };
  auto flight = [&](int wingbeats) {
    FlightResult r;
    for (int k = 0; k <= 20 * wingbeats; ++k) {
      FlightSample s;
      s.t = k * T / 20;
      s.x = BodyStateVector::Zero();
      s.x(10) = 1e-3 * std::exp(0.3 * s.t / T);  // theta, rad
      r.samples.push_back(s);
    }
    return r;
  };
  const GrowthEstimate one = wingbeat_growth(flight(1), orbit, ref, T, {10}, 3);
  EXPECT_EQ(one.first, 0);
  EXPECT_EQ(one.last, 0);
  EXPECT_TRUE(std::isnan(one.per_wingbeat));
  EXPECT_TRUE(std::isnan(one.mean_per_wingbeat));
  const GrowthEstimate four = wingbeat_growth(flight(4), orbit, ref, T, {10}, 3);
  EXPECT_EQ(four.first, 2);
  EXPECT_EQ(four.last, 3);
  EXPECT_NEAR(four.mean_per_wingbeat, 0.3, 1e-9);
  EXPECT_GT(four.per_wingbeat, 0.3);  // the last wingbeat's maximum is its closing sample, one sample later
}

}  // namespace
}  // namespace flapstab
