// Control derivatives, closed-loop assembly, and the delayed pitch loop of the hawkmoth: averaged, periodic and
// nonlinear simulated answers side by side.
#include <gtest/gtest.h>

#include <cmath>

#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "common/case_text.hpp"
#include "flight/control_derivatives.hpp"
#include "flight/controller.hpp"
#include "core/rotation.hpp"
#include "flight/free_flight.hpp"
#include "flight/hover_model.hpp"

namespace flapstab {
namespace {

struct Loop {
  Case c;
  std::unique_ptr<AeroModel> model;
  HoverModel h;
  double trim = 0;  // trimmed stroke-plane angle (deg)
};

const Loop& hawkmoth() {
  static const Loop l = [] {
    Loop x;
    x.c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml");
    x.model = make_aero_model(x.c);
    x.h = hover_model(x.c, *x.model, {unbounded_parameter("stroke_plane_deg"), unbounded_parameter("frequency_hz")});
    x.trim = x.h.cyclic.kinematics.stroke_plane / deg;
    return x;
  }();
  return l;
}

// Quasi-steady loads at rest scale with the square of the wingbeat frequency (every term: translational and
// rotational circulation, added mass), so dF/dn = 2 F / n exactly; central differences of a quadratic are exact,
// leaving rounding (1e-9 relative). The frequency does not move the mean centre of mass: no gravity part.
TEST(ControlDerivatives, FrequencyDerivativeIsTwiceTheLoadOverFrequency) {
  const Loop& l = hawkmoth();
  const Kinematics& k = l.h.cyclic.kinematics;
  const Wrench w = l.model->run(l.c.insect, k, BodyMotion{}, {}).mean();
  const Eigen::VectorXd col = l.h.control.si.col(1);
  const double n = k.frequency_hz;
  EXPECT_NEAR(col(2), 2 * w.force.z() / n, 1e-9 * std::abs(w.force.z() / n));
  EXPECT_NEAR(col(0), 2 * w.force.x() / n, 1e-9 * std::abs(w.force.z() / n));
  EXPECT_NEAR(col(4), 2 * w.moment.y() / n, 1e-9 * std::abs(w.force.z() / n) * l.c.insect.wing.length);
  // Zero but for rounding: the CoM over a wingbeat sampled at other instants (5e-22 N m/Hz measured, 1e-17 of the
  // W R / n scale).
  EXPECT_LT(l.h.control.gravity_si.col(1).norm(), 1e-12 * l.c.insect.weight() * l.c.insect.wing.length / n);
  // At the averaged trim the mean lift carries the weight: dZ/dn = -2 W / n. (The cyclic trim's kinematics, used
  // above, balance the weight along the oscillating orbit, not at rest.)
  const TrimParameterSpec f = unbounded_parameter("frequency_hz");
  const Kinematics& ka = l.h.averaged_trim.kinematics;
  const ControlDerivativeResult at_rest =
      control_derivatives(*l.model, l.c.insect, ka, {f}, l.h.derivatives.table.reference);
  EXPECT_NEAR(at_rest.si(2, 0), -2 * l.c.insect.weight() / ka.frequency_hz, 1e-8 * l.c.insect.weight() / n);
}

// Abdominal flexion as an actuator (abdomen_flexion_deg): it moves no wing, so its control derivative is the weight's
// moment of the CoM shift alone. For the rigid abdomen of the example hawkmoth (CoM c from the joint, A axes) a
// flexion delta turns c about the joint's y axis: dp/d delta = y x c = (c_z, 0, -c_x) in A, whose x component in S
// (A pitched nose-up by the body angle chi: x_S = v_x cos chi + v_z sin chi) is c_z cos chi - c_x sin chi; the
// moment of the weight (+z in S) about O is then dM/d delta = -m_a g dx_S/d delta (nose-down for a forward shift). The
// central difference over +-0.5 deg of this sinusoid is the derivative times sin h / h exactly, so the hand value
// holds to rounding (1e-9 relative); the forces and the aerodynamic share are zero (1e-12 of W, W R per deg).
TEST(ControlDerivatives, AbdominalFlexionIsTheWeightsMomentOfTheCoMShift) {
  std::string text = testing::read_file(std::string(FLAPSTAB_SOURCE_DIR) + "/data/examples/abdomen_hawkmoth.toml");
  text = testing::replace(text, "mean_deg = 0.0\ncos_deg = [5.0]", "mean_deg = 0.0");
  const Case c = load_case(testing::write_temp("flexion_control.toml", text));
  ASSERT_TRUE(c.insect.abdomen);
  const auto model = make_aero_model(c);
  const TrimResult t = trim_hover(c, *model);
  ASSERT_TRUE(t.converged);
  const ReferenceQuantities ref = reference_quantities(c.insect, t.kinematics, c.fluid);
  const ControlDerivativeResult r =
      control_derivatives(*model, c.insect, t.kinematics, {unbounded_parameter("abdomen_flexion_deg")}, ref);
  const Abdomen& a = *c.insect.abdomen;
  const double chi = t.kinematics.body_angle, h = 0.5 * deg;
  const double dx_s = a.centre.z() * std::cos(chi) - a.centre.x() * std::sin(chi);  // per rad of flexion
  const double expected = -a.mass * c.insect.gravity * dx_s * deg * std::sin(h) / h;  // N m per deg
  const double W = c.insect.weight(), R = c.insect.wing.length;
  std::printf("    dM/d(flexion) = %.10e N m/deg, hand %.10e\n", r.si(4, 0), expected);
  EXPECT_NEAR(r.si(4, 0), expected, 1e-9 * std::abs(expected));
  EXPECT_LT(expected, 0);  // a ventral flexion moves the CoM forward: nose-down
  for (int i : {0, 1, 2}) EXPECT_LT(std::abs(r.si(i, 0)), 1e-12 * W) << i;
  for (int i : {3, 5}) EXPECT_LT(std::abs(r.si(i, 0)), 1e-12 * W * R) << i;
  EXPECT_LT((r.si.col(0) - r.gravity_si.col(0)).norm(), 1e-12 * W * R);
}

// The loop's assembly: with zero latency the roots are the eigenvalues of A - b k^T; a sensor filter adds the
// state s' = (theta - s) / T_f with the command -k s (the augmented matrix written out by hand). To 1e-9.
TEST(ClosedLoop, ZeroLatencyAndFilterMatchTheStateFeedbackMatrix) {
  const LinearPlant& p = hawkmoth().h.longitudinal;
  PitchControllerSettings s;
  s.pitch_gain = 0.7;
  s.rate_gain_s = 0.03;
  const ControllerSpec c = pitch_controller(s, hawkmoth().trim);
  Eigen::Matrix4d K = Eigen::Matrix4d::Zero();
  K.col(3) = -c.terms[0].gain * p.B.col(0);
  K.col(2) = -c.terms[1].gain * p.B.col(0);
  const Eigen::VectorXcd expected = Eigen::EigenSolver<Eigen::MatrixXd>(p.A + K).eigenvalues();
  const DelayRoots r = rightmost_roots(closed_loop(p, c));
  double abscissa = -1e300;
  for (Eigen::Index i = 0; i < 4; ++i) abscissa = std::max(abscissa, expected(i).real());
  EXPECT_NEAR(r.spectral_abscissa(), abscissa, 1e-9 * std::abs(abscissa) + 1e-9);
  s.filter_time_s = 0.01;
  const ControllerSpec cf = pitch_controller(s, hawkmoth().trim);
  Eigen::MatrixXd Af = Eigen::MatrixXd::Zero(6, 6);
  Af.topLeftCorner(4, 4) = p.A;
  Af(4, 4) = Af(5, 5) = -100;
  Af(4, 3) = Af(5, 2) = 100;  // filter states sense theta and q
  Af.block(0, 4, 4, 1) = -cf.terms[0].gain * p.B.col(0);
  Af.block(0, 5, 4, 1) = -cf.terms[1].gain * p.B.col(0);
  const DelaySystem d = closed_loop(p, cf);
  ASSERT_EQ(d.A.rows(), 6);
  EXPECT_LT((d.A - Af).norm(), 1e-9 * Af.norm());
}

// The delayed pitch loop (0.5 deg/deg, 0.05 s) at latencies well inside (20 ms) and well beyond (90 ms) the averaged
// model's critical latency (55 ms): averaged, periodic and nonlinear simulated answers agree on the sign of the
// growth. The simulated growth is fitted to the per-wingbeat deviation over wingbeats 10-19; both points are chosen
// at least 0.05 per wingbeat from neutral in the linear models, so only the sign is asserted.
TEST(ClosedLoop, DelayedPitchFeedbackAveragedPeriodicAndSimulatedAgree) {
  const Loop& l = hawkmoth();
  const double T = l.h.cyclic.period;
  PitchControllerSettings s;
  s.pitch_gain = 0.5;
  s.rate_gain_s = 0.05;
  const FlightDynamics dyn(*l.model, l.c.insect, l.h.cyclic.kinematics, pitch_controller(s, l.trim).actuators,
                           DofSet::longitudinal);
  const PeriodicPlant pp = periodic_plant(dyn, l.h.phase, {"u", "w", "q", "theta"});
  const ReferenceOrbit ref = reference_orbit(l.h.orbit, T);
  for (double tau : {0.020, 0.090}) {
    s.pitch_latency_s = s.rate_latency_s = tau;
    const ControllerSpec c = pitch_controller(s, l.trim);
    const double lti = rightmost_roots(closed_loop(l.h.longitudinal, c)).spectral_abscissa() * T;
    const DelayFloquet fl = delayed_floquet(closed_loop(pp, c));
    EXPECT_TRUE(fl.converged);
    const double periodic = std::log(fl.spectral_radius());
    BodyStateVector x0 = l.h.cyclic.initial_state;
    x0(10) += 0.5 * deg;
    FlightOptions o;
    o.wingbeats = 20;
    const FlightResult r = simulate_flight(dyn, c, x0, ref, l.h.derivatives.table.reference, o);
    ASSERT_TRUE(r.completed) << r.stop_reason;
    const double sim = wingbeat_growth(r, ref, l.h.derivatives.table.reference, T, {3, 5, 7, 10}, 10).per_wingbeat;
    const bool stable = tau < 0.05;
    EXPECT_EQ(lti < -0.05, stable) << "tau " << tau << ": averaged " << lti;
    EXPECT_EQ(periodic < -0.05, stable) << "tau " << tau << ": periodic " << periodic;
    EXPECT_EQ(sim < 0, stable) << "tau " << tau << ": simulated " << sim;
    if (!stable) {
      EXPECT_GT(lti, 0.05);
    }
  }
}

// Sample-and-hold: the command changes only at wingbeat boundaries.
TEST(ClosedLoop, WingbeatUpdateHoldsTheCommandForEachWingbeat) {
  const Loop& l = hawkmoth();
  PitchControllerSettings s;
  s.pitch_gain = 0.5;
  s.rate_gain_s = 0.05;
  s.pitch_latency_s = s.rate_latency_s = 0.02;
  s.update = ControlUpdate::wingbeat;
  const ControllerSpec c = pitch_controller(s, l.trim);
  const FlightDynamics dyn(*l.model, l.c.insect, l.h.cyclic.kinematics, c.actuators, DofSet::longitudinal);
  BodyStateVector x0 = l.h.cyclic.initial_state;
  x0(10) += 0.5 * deg;
  FlightOptions o;
  o.wingbeats = 3;
  o.samples_per_wingbeat = 10;
  const FlightResult r = simulate_flight(dyn, c, x0, reference_orbit(l.h.orbit, l.h.cyclic.period),
                                         l.h.derivatives.table.reference, o);
  ASSERT_EQ(r.samples.size(), 31u);
  double changed = 0;
  for (int k = 0; k < 3; ++k)
    for (int i = 1; i < 10; ++i)
      EXPECT_EQ(r.samples[std::size_t(10 * k + i)].command[0], r.samples[std::size_t(10 * k)].command[0]);
  for (int k = 1; k < 3; ++k) changed += std::abs(r.samples[std::size_t(10 * k)].command[0] - r.samples[0].command[0]);
  EXPECT_GT(changed, 1e-3);  // the held value does follow the (delayed) pitch
}

// Actuator limits: the command saturates at trim -/+ limit_deg and never passes it.
TEST(ClosedLoop, CommandSaturatesAtTheActuatorLimit) {
  const Loop& l = hawkmoth();
  PitchControllerSettings s;
  s.pitch_gain = 0.5;
  s.rate_gain_s = 0.05;
  s.pitch_latency_s = s.rate_latency_s = 0.02;
  s.limit_deg = 0.05;
  const ControllerSpec c = pitch_controller(s, l.trim);
  const FlightDynamics dyn(*l.model, l.c.insect, l.h.cyclic.kinematics, c.actuators, DofSet::longitudinal);
  BodyStateVector x0 = l.h.cyclic.initial_state;
  x0(10) += 0.5 * deg;  // unsaturated the command would reach -0.25 deg
  FlightOptions o;
  o.wingbeats = 2;
  const FlightResult r = simulate_flight(dyn, c, x0, reference_orbit(l.h.orbit, l.h.cyclic.period),
                                         l.h.derivatives.table.reference, o);
  double lo = 0;
  for (const auto& smp : r.samples) {
    EXPECT_LE(std::abs(smp.command[0]), 0.05 + 1e-12);
    lo = std::min(lo, smp.command[0]);
  }
  EXPECT_NEAR(lo, -0.05, 1e-12);
}

// The neutral axis belongs to the wings: moving the centre of mass 0.25 c down relative to the hinges (re-trimmed)
// moves the CoM 0.25 c further below the axis, to 2 % of the chord.
TEST(NeutralAxis, MovesWithTheWingsNotWithTheCentreOfMass) {
  const Loop& l = hawkmoth();
  const double cbar = l.h.derivatives.table.reference.c;
  const NeutralAxis a0 = neutral_axis(l.h.derivatives.table);
  EXPECT_LT(a0.z_at_com, 0);  // above the CoM for the hovering hawkmoth (X_u < 0, M_u > 0)
  Case m = l.c;
  m.insect.wing.hinge -= rot_y(l.c.kinematics.body_angle).transpose() * Vec3(0, 0, 0.25 * cbar);
  CyclicTrimOptions co;
  co.tolerance = 1e-8;
  const HoverModel h = hover_model(m, *l.model, {}, 0, co);
  const NeutralAxis a1 = neutral_axis(h.derivatives.table);
  EXPECT_NEAR(a1.com_below_axis_m - a0.com_below_axis_m, 0.25 * cbar, 0.02 * cbar);
}

}  // namespace
}  // namespace flapstab
