// Cyclic hover trim by shooting: the CVODES wrapper's sensitivities against exact answers, and the
// converged orbit of a small, fast insect (the dronefly case) against independent re-integration.
#include <gtest/gtest.h>

#include <cmath>
#include <unsupported/Eigen/MatrixFunctions>

#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "cfd/phase_derivatives.hpp"
#include "common/case_text.hpp"
#include "core/eom.hpp"
#include "core/errors.hpp"
#include "trim/cyclic.hpp"
#include "trim/ode.hpp"

namespace flapstab {
namespace {

// Linear x' = A x: x(t) = exp(A t) x0 and the sensitivity is exp(A t) itself. Tolerance 1e-8 relative
// (rtol 1e-12; sensitivities by directional differences, exact for a linear f up to rounding).
TEST(OdeWrapper, LinearSystemSensitivitiesAreTheMatrixExponential) {
  Eigen::Matrix3d A;
  A << -0.5, 3.0, 0.0, -3.0, -0.1, 0.2, 0.1, 0.0, -1.0;
  const OdeRhs f = [&](double, const Eigen::VectorXd& x, Eigen::VectorXd& dx) { dx = A * x; };
  const Eigen::Vector3d x0(1, -2, 0.5);
  const OdeSolution s = integrate_ode(f, x0, 0, 2.0, {0, 1, 2}, {0.0, 1.0});
  const Eigen::Matrix3d E = (A * 2.0).exp();
  EXPECT_LT((s.x - E * x0).norm(), 1e-9 * x0.norm());
  EXPECT_LT((s.sensitivity - E).norm(), 1e-8 * E.norm());
  ASSERT_EQ(s.samples.size(), 2u);
  EXPECT_LT((s.samples[1] - (A * 1.0).exp() * x0).norm(), 1e-9);
  EXPECT_LT((s.samples[0] - x0).norm(), 1e-15);
}

// Nonlinear pendulum x'' = -sin x: the sensitivity of x(t) to x(0) against central differences of the
// flow (step 1e-6, rtol 1e-13: agreement to 1e-6).
TEST(OdeWrapper, NonlinearSensitivityMatchesFlowDifferences) {
  const OdeRhs f = [](double, const Eigen::VectorXd& x, Eigen::VectorXd& dx) {
    dx.resize(2);
    dx << x(1), -std::sin(x(0));
  };
  OdeOptions o;
  o.rtol = 1e-13;
  const Eigen::Vector2d x0(1.0, 0.3);
  const OdeSolution s = integrate_ode(f, x0, 0, 5.0, {0, 1}, {}, o);
  for (int j = 0; j < 2; ++j) {
    Eigen::Vector2d p = x0, m = x0;
    p(j) += 1e-6;
    m(j) -= 1e-6;
    const Eigen::VectorXd col = (integrate_ode(f, p, 0, 5.0, {}, {}, o).x - integrate_ode(f, m, 0, 5.0, {}, {}, o).x) / 2e-6;
    EXPECT_LT((s.sensitivity.col(j) - col).norm(), 1e-6 * col.norm()) << "column " << j;
  }
}

struct Dronefly {
  Case c;
  std::unique_ptr<AeroModel> model;
  TrimResult averaged;
  CyclicTrimResult cyclic;
};

const Dronefly& dronefly() {
  static const Dronefly d = [] {
    Dronefly x;
    x.c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/dronefly.toml");
    x.model = make_aero_model(x.c);
    x.averaged = trim_hover(x.c, *x.model);
    x.cyclic = cyclic_trim(x.c, *x.model, x.averaged);
    return x;
  }();
  return d;
}

// The requirement: periodicity residual <= 1e-10 (scaled: velocities / U, rates c / U, rad,
// drifts / c); the lateral states stay zero by symmetry; the mean attitude is zero.
TEST(CyclicTrim, DroneflyConvergesToAPeriodicOrbit) {
  const CyclicTrimResult& r = dronefly().cyclic;
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_LE(r.residual, 1e-10);
  EXPECT_LT(r.symmetry_residual, 1e-12);
  EXPECT_LT(std::abs(r.mean_theta), 1e-10);
  EXPECT_GT(r.amplitude_si(2), 0);  // the body does rock within the wingbeat
  ASSERT_EQ(r.parameters.size(), 3u);
}

// Independent check: integrate the converged orbit again (a different tolerance, 1e-11) and compare
// x(T) with x(0): periodic to 1e-8 of the scales, and no net drift.
TEST(CyclicTrim, ReintegratedOrbitReturnsToItsStart) {
  const Dronefly& d = dronefly();
  const InstantaneousAero aero(*d.model, d.c.insect, d.cyclic.kinematics);
  const OdeRhs f = [&](double t, const Eigen::VectorXd& x, Eigen::VectorXd& dx) {
    dx = free_flight_derivative(aero, t, x.head<12>());
  };
  OdeOptions o;
  o.rtol = 1e-11;
  const double T = d.cyclic.period;
  const OdeSolution s = integrate_ode(f, d.cyclic.initial_state, 0, T, {}, {}, o);
  const double U = 2 * d.cyclic.kinematics.stroke_amplitude() * d.cyclic.kinematics.frequency_hz *
                   d.c.insect.wing.radius_of_moment(2);
  const double c = d.c.insect.wing.mean_chord;
  const BodyStateVector x0 = d.cyclic.initial_state;
  EXPECT_LT(std::abs(s.x(3) - x0(3)) / U, 1e-8);
  EXPECT_LT(std::abs(s.x(5) - x0(5)) / U, 1e-8);
  EXPECT_LT(std::abs(s.x(7) - x0(7)) * c / U, 1e-8);
  EXPECT_LT(std::abs(s.x(10) - x0(10)), 1e-8);
  EXPECT_LT(std::abs(s.x(0)) / c, 1e-8);
  EXPECT_LT(std::abs(s.x(2)) / c, 1e-8);
}

// The monodromy (route 2) against central differences of the period map about the orbit, column by
// column for the longitudinal states (step 1e-6 of the scales, rtol 1e-12: agreement to 1e-5).
TEST(CyclicTrim, MonodromyMatchesPeriodMapDifferences) {
  const Dronefly& d = dronefly();
  const InstantaneousAero aero(*d.model, d.c.insect, d.cyclic.kinematics);
  const OdeRhs f = [&](double t, const Eigen::VectorXd& x, Eigen::VectorXd& dx) {
    dx = free_flight_derivative(aero, t, x.head<12>());
  };
  const double T = d.cyclic.period;
  const double U = 2 * d.cyclic.kinematics.stroke_amplitude() * d.cyclic.kinematics.frequency_hz *
                   d.c.insect.wing.radius_of_moment(2);
  const double c = d.c.insect.wing.mean_chord;
  const int states[4] = {3, 5, 7, 10};
  const double scales[4] = {U, U, U / c, 1.0};
  for (int j = 0; j < 4; ++j) {
    Eigen::VectorXd p = d.cyclic.initial_state, m = p;
    const double h = 1e-6 * scales[j];
    p(states[j]) += h;
    m(states[j]) -= h;
    const Eigen::VectorXd col = (integrate_ode(f, p, 0, T).x - integrate_ode(f, m, 0, T).x) / (2 * h);
    for (int i = 0; i < 4; ++i) {
      const double expected = col(states[i]) * scales[j] / scales[i];
      const double got = d.cyclic.monodromy(states[i] - 3, states[j] - 3) * scales[j] / scales[i];
      EXPECT_NEAR(got, expected, 1e-5 * std::max(1.0, std::abs(expected))) << i << "," << j;
    }
  }
}

// The exact Jacobian option: for x' = A x with options.jacobian = A the sensitivities are exp(A t) as with the
// differenced ones (1e-8 relative).
TEST(OdeWrapper, ExactJacobianGivesTheSameSensitivities) {
  Eigen::Matrix3d A;
  A << -0.5, 3.0, 0.0, -3.0, -0.1, 0.2, 0.1, 0.0, -1.0;
  const OdeRhs f = [&](double, const Eigen::VectorXd& x, Eigen::VectorXd& dx) { dx = A * x; };
  OdeOptions o;
  o.jacobian = [&](double, const Eigen::VectorXd&, Eigen::MatrixXd& J) { J = A; };
  const Eigen::Vector3d x0(1, -2, 0.5);
  const OdeSolution s = integrate_ode(f, x0, 0, 2.0, {0, 1, 2}, {}, o);
  const Eigen::Matrix3d E = (A * 2.0).exp();
  EXPECT_LT((s.x - E * x0).norm(), 1e-9 * x0.norm());
  EXPECT_LT((s.sensitivity - E).norm(), 1e-8 * E.norm());
}

// The free system's exact Jacobian (loads_jacobian through body_state_jacobian) against central differences of
// free_flight_derivative (steps 1e-6 of U, U / c, rad) along the dronefly's cyclic orbit at a perturbed state:
// agreement to 1e-7 in the scaled units (states / [c, U, U / c, rad], time c / U).
TEST(CyclicTrim, FreeSystemJacobianMatchesFiniteDifferences) {
  const Dronefly& d = dronefly();
  const auto* qs = dynamic_cast<const QuasiSteadyModel*>(d.model.get());
  ASSERT_NE(qs, nullptr);
  const InstantaneousAero aero(*d.model, d.c.insect, d.cyclic.kinematics);
  const SpanQuadrature span = span_quadrature(d.c.insect.wing, qs->options().blade_elements);
  const ReferenceQuantities ref = reference_quantities(d.c.insect, d.cyclic.kinematics, d.c.fluid);
  const std::vector<BodyStateVector> orbit = periodic_orbit(aero, d.cyclic.initial_state, 8);
  for (std::size_t k = 0; k < orbit.size(); ++k) {
    const double t = d.cyclic.period * double(k) / 8;
    BodyStateVector x = orbit[k];
    x.segment<3>(3) += Eigen::Vector3d(0.05, 0.03, -0.02) * ref.U;
    x.segment<3>(6) += Eigen::Vector3d(-0.04, 0.02, 0.05) * ref.U / ref.c;
    x.segment<3>(9) += Eigen::Vector3d(0.1, -0.05, 0.2);
    Eigen::Matrix<double, 6, 6> dw;
    qs->loads_jacobian(aero.configuration(), span, t, body_motion(x), dw);
    const Eigen::Matrix<double, 12, 12> J = body_state_jacobian(aero.configuration(), t, x, dw);
    BodyStateVector scale;  // of each state; its rate's scale is scale * U / c
    for (int i = 0; i < 12; ++i) scale(i) = i < 3 ? ref.c : i < 6 ? ref.U : i < 9 ? ref.U / ref.c : 1.0;
    for (int j = 0; j < 12; ++j) {
      const double s = scale(j), h = 1e-6 * s;
      BodyStateVector xp = x, xm = x;
      xp(j) += h;
      xm(j) -= h;
      const BodyStateVector fd = (free_flight_derivative(aero, t, xp) - free_flight_derivative(aero, t, xm)) / (2 * h);
      const double err = ((fd - J.col(j)) * s).cwiseQuotient(scale * (ref.U / ref.c)).cwiseAbs().maxCoeff();
      EXPECT_LT(err, 1e-7) << "phase " << k << " column " << j;
    }
  }
}

// [trim] cyclic_attitude = "free". With the stroke plane fixed to the body (stroke_plane_reference = "body"), a change
// of body_angle_deg turns the whole insect rigidly in the stability axes, and in hover (air at rest) the loads in
// body axes do not change: it is the same as a mean pitch theta of the free orbit. So the dronefly trimmed with
// body_angle_deg for the horizontal force in place of pitch_mean_deg (imposed: the orbit's mean theta is zero, the body angle solved) and the
// same case with the attitude free (body angle held at the averaged trim's value, the orbit's mean theta solved)
// must find the same orbit (the hawkmoth: slow wingbeat, heavy wings, so the cyclic trim moves the body angle by
// 0.08 deg from the averaged trim's): the free trim's reported mean attitude equals the imposed trim's body angle, and the
// other two parameters agree. Tolerances: 1e-8 rad and 1e-7 deg (Newton to 1e-10 in the scaled residual).
TEST(CyclicTrim, FreeAttitudeFindsTheImposedTrimsBodyAngle) {
  const std::string source = std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml";
  std::string text = testing::read_file(source);
  text = testing::replace(text, "stroke_plane_deg = -15.0", "stroke_plane_reference = \"body\"\nstroke_plane_deg = -49.3");
  text = testing::replace(text, "name = \"pitch_mean_deg\"", "name = \"body_angle_deg\"");
  text = testing::replace(text, "lower = 70.0 ", "lower = 20.0 ");
  text = testing::replace(text, "upper = 110.0", "upper = 80.0");
  const Case imposed = load_case(testing::write_temp("cyclic_imposed.toml", text));
  const Case free = load_case(testing::write_temp(
      "cyclic_free.toml", testing::replace(text, "max_iterations = 200\n", "max_iterations = 200\ncyclic_attitude = \"free\"\n")));
  ASSERT_EQ(free.trim.cyclic_attitude, "free");
  const auto model = make_aero_model(imposed);
  const TrimResult averaged = trim_hover(imposed, *model);
  ASSERT_TRUE(averaged.converged);
  const CyclicTrimResult a = cyclic_trim(imposed, *model, averaged), b = cyclic_trim(free, *model, averaged);
  ASSERT_TRUE(a.converged) << a.message;
  ASSERT_TRUE(b.converged) << b.message;
  EXPECT_FALSE(a.free_attitude);
  EXPECT_TRUE(b.free_attitude);
  ASSERT_EQ(a.parameters.size(), 3u);
  ASSERT_EQ(b.parameters.size(), 2u);  // body_angle_deg held
  EXPECT_EQ(b.residual_names.size(), 6u);
  EXPECT_LT(std::abs(a.mean_theta), 1e-10);
  EXPECT_NEAR(b.kinematics.body_angle, averaged.kinematics.body_angle, 1e-15);
  // The cyclic trim moves the body angle away from the averaged trim's, so the free orbit does pitch on average.
  std::printf("averaged body angle %.10f deg, imposed cyclic %.10f deg, free mean attitude %.10f deg\n",
              averaged.kinematics.body_angle / deg, a.kinematics.body_angle / deg, b.mean_body_angle / deg);
  EXPECT_GT(std::abs(a.kinematics.body_angle - averaged.kinematics.body_angle), 1e-5);
  EXPECT_NEAR(b.mean_body_angle, a.kinematics.body_angle, 1e-8);
  EXPECT_NEAR(a.mean_body_angle, a.kinematics.body_angle, 1e-10);
  for (std::size_t i = 0, j = 0; i < a.parameters.size(); ++i) {
    if (a.parameters[i].name == "body_angle_deg") continue;
    EXPECT_EQ(a.parameters[i].name, b.parameters[j].name);
    EXPECT_NEAR(a.parameters[i].value, b.parameters[j].value, 1e-7) << a.parameters[i].name;
    ++j;
  }
  // The same orbit: the attitude's oscillation and the speed over the wingbeat (u, w turn with the axes).
  EXPECT_NEAR(a.amplitude_si(3), b.amplitude_si(3), 1e-9);
  EXPECT_NEAR(a.amplitude_si(2), b.amplitude_si(2), 1e-7 * a.amplitude_si(2));
  EXPECT_NEAR(std::hypot(a.initial_state(3), a.initial_state(5)), std::hypot(b.initial_state(3), b.initial_state(5)),
              1e-8 * reference_quantities(imposed.insect, a.kinematics, imposed.fluid).U);
}

// "free" needs body_angle_deg among the [trim] parameters (the averaged trim's moment or force balance that the
// orbit's mean pitch replaces); without it the case is refused naming the key.
TEST(CyclicTrim, FreeAttitudeWithoutBodyAngleParameterIsRefused) {
  const std::string source = std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/dronefly.toml";
  const std::string text = testing::replace(testing::read_file(source), "max_iterations = 200\n",
                                            "max_iterations = 200\ncyclic_attitude = \"free\"\n");
  const std::string path = testing::write_temp("cyclic_free_bad.toml", text);
  try {
    load_case(path);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("trim.cyclic_attitude"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("body_angle_deg"), std::string::npos) << e.what();
  }
  const std::string bad = testing::write_temp(
      "cyclic_free_value.toml", testing::replace(text, "cyclic_attitude = \"free\"", "cyclic_attitude = \"loose\""));
  EXPECT_THROW(load_case(bad), InputError);
}

}  // namespace
}  // namespace flapstab
