// Free flight coupled to the Navier-Stokes solver (flight/cfd_flight.hpp, cfd/navier_stokes/free_body.hpp).
//
// Validation (docs/validation.md, "Fluid-body coupling"):
//  - a sphere settling freely under gravity from rest in fluid at rest, density ratio 2, reaches the terminal
//    velocity of the standard drag curve (Clift, Grace & Weber 1978, Bubbles, Drops and Particles, Table 5.2:
//    C_D = 24/Re (1 + 0.1935 Re^0.6305), 20 <= Re <= 260) at Re ~ 20; its early acceleration is that of the
//    weight less buoyancy against the mass plus the added mass rho_f V / 2 (potential flow; the Basset history
//    force grows from zero as t^1/2);
//  - a neutrally buoyant sphere released in fluid at rest stays at rest.
#include <gtest/gtest.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <optional>
#include "cfd/navier_stokes/free_body.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/navier_stokes/operators.hpp"
#include "core/rotation.hpp"

namespace {

using namespace flapstab;
using namespace flapstab::ns;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Standard drag curve (Clift, Grace & Weber 1978, Table 5.2).
double standard_drag(double re) {
  if (re > 20) return 24 / re * (1 + 0.1935 * std::pow(re, 0.6305));
  const double w = std::log10(re);
  return 24 / re * (1 + 0.1315 * std::pow(re, 0.82 - 0.05 * w));
}

// Terminal velocity of a sphere (diameter D, density ratio s) from the curve: (s - 1) g D 4/3 = C_D(Re) U^2.
double terminal_velocity(double D, double s, double g, double nu) {
  double lo = 1e-6, hi = 100;
  for (int i = 0; i < 200; ++i) {
    const double u = std::sqrt(lo * hi);
    const double lhs = (s - 1) * g * D * 4 / 3, rhs = standard_drag(u * D / nu) * u * u;
    (rhs > lhs ? hi : lo) = u;
  }
  return std::sqrt(lo * hi);
}

// A sphere of density ratio s free to translate (no rotation: a sphere's torque is small and it does not change
// its drag), coupled explicitly with the loads of the step's start held (the scheme of flight/cfd_flight.hpp, with
// the same free_body helpers). Closed box of walls, gravity +z.
struct SettlingSphere {
  double D = 1, s = 2, g = 1, nu = 0.05, h = 0.125;
  bool exchange = true;  // momentum-exchange loads (the insects' default), else the surface integral
  struct Sample {
    double t, w, a;
    // Energy (fluid density 1): the net weight's work (m - rho V) g z, the body's kinetic energy, the fluid's (the
    // grid's, including the forced fluid inside the sphere) and the kinetic energy the discrete viscous term has
    // removed so far (trapezoid of viscous_dissipation over the steps).
    double work = 0, body = 0, fluid = 0, dissipated = 0;
  };
  std::vector<Sample> run(double t_end, double fall) const {
    const Grid grid(Axis::stretched(StretchedAxis{-5, 5, -0.8, 0.8, h, 1.1, 8}, false),
                    Axis::stretched(StretchedAxis{-5, 5, -0.8, 0.8, h, 1.1, 8}, false),
                    Axis::stretched(StretchedAxis{-4, fall + 4, -0.8, fall + 0.8, h, 1.1, 8}, false));
    SolverOptions opt;
    opt.nu = nu;
    opt.cfl = 0.8;
    opt.dt_max = 0.05 * D / terminal_velocity(D, std::max(s, 1.5), g, nu);
    Solver solver(grid, Boundaries::all(BC::velocity), opt);
    solver.initialise([](double, double, double) { return Vec3::Zero(); });
    const TriangleMesh mesh = sphere_mesh(D / 2, 16);
    ImmersedBoundary ib(grid, ImmersedOptions{.density = 1.0});
    const double V = pi * D * D * D / 6, m = s * V;  // fluid density 1
    // Body state: position, velocity (body = grid axes: no rotation), the rest held at zero.
    BodyStateVector x = BodyStateVector::Zero();
    Vec3 held = Vec3::Zero();  // fluid force at the step's start
    double t_base = 0;
    BodyStateVector x_base = x;
    auto rhs = [&](double, const BodyStateVector& y) {
      BodyStateVector d = BodyStateVector::Zero();
      d.segment<3>(0) = y.segment<3>(3);
      d.segment<3>(3) = (held + Vec3(0, 0, (m - V) * g)) / m;
      return d;
    };
    auto body_at = [&](double t) { return integrate_body(rhs, t_base, x_base, t, 2); };
    auto parts_at = [&](double t) {
      const BodyStateVector y = body_at(t);
      return std::vector<PartState>{part_in_grid(body_frame(y, rhs(t, y)), PartState{})};
    };
    ib.add_part(mesh, parts_at(0)[0]);
    struct Hooks : StageHooks {
      ImmersedBoundary* ib;
      std::function<std::vector<PartState>(double)> parts;
      void after_predictor(VectorField& u, double t, double adt) override {
        ib->set_parts(t, parts(t));
        ib->after_predictor(u, t, adt);
      }
      void after_projection(VectorField& u, Field& p, double t) override { ib->after_projection(u, p, t); }
    } hooks;
    hooks.ib = &ib;
    hooks.parts = parts_at;
    ib.set_parts(0, parts_at(0));
    ib.attach(solver);
    solver.attach(&hooks);
    std::vector<Sample> out;
    double dissipated = 0, rate = 0;
    while (solver.time() < t_end - 1e-12) {
      t_base = solver.time();
      x_base = x;
      solver.step();
      x = body_at(solver.time());
      const auto L = exchange ? ib.exchange_loads(solver, Vec3::Zero()) : ib.loads(solver, Vec3::Zero());
      held = wrench_on_body(body_frame(x, BodyStateVector::Zero()), L[0].force(), L[0].moment()).force;
      const double r_now = viscous_dissipation(grid, solver.velocity(), nu);
      dissipated += 0.5 * (rate + r_now) * (solver.time() - t_base);
      rate = r_now;
      out.push_back({solver.time(), x(5), rhs(0, x)(5), (m - V) * g * x(2), 0.5 * m * x(5) * x(5),
                     solver.kinetic_energy(), dissipated});
      if (x(2) > fall) break;
    }
    return out;
  }
};

// The Basset-Boussinesq-Oseen equation of a sphere released from rest (Maxey & Riley 1983, Phys Fluids 26:883):
// (m + m_a) U' = (m - m_f) g - 3 pi mu D U - (3/2) D^2 sqrt(pi rho mu) int_0^t U'(s) / sqrt(t - s) ds, the history
// integral with U' piecewise constant (product integration, implicit in the newest interval). Valid while the
// particle Reynolds number is small (early times). Returns U(t_end).
double bbo_velocity(double D, double s, double g, double nu, double t_end, int n = 4000) {
  const double V = pi * D * D * D / 6, m = s * V, ma = V / 2, mu = nu, K = 1.5 * D * D * std::sqrt(pi * mu);
  const double dt = t_end / n;
  std::vector<double> a;
  double U = 0;
  for (int k = 0; k < n; ++k) {
    const double t = (k + 1) * dt;
    // history of the earlier intervals at t; the newest interval's weight multiplies the unknown a_k
    double hist = 0;
    for (int j = 0; j < k; ++j) hist += a[std::size_t(j)] * 2 * (std::sqrt(t - j * dt) - std::sqrt(t - (j + 1) * dt));
    const double w_new = 2 * std::sqrt(dt);
    // (m + ma) a_k = (m - V) g - 3 pi mu D (U + a_k dt) - K (hist + a_k w_new)
    const double ak = ((m - V) * g - 3 * pi * mu * D * U - K * hist) / (m + ma + 3 * pi * mu * D * dt + K * w_new);
    a.push_back(ak);
    U += ak * dt;
  }
  return U;
}

// The drag of the same sphere held fixed in a uniform stream U on the same grid (inflow at z-, outflow at z+,
// the lateral faces at U), mean over the last quarter of t in [0, t_end]: the load the coupled sphere settles on.
double fixed_sphere_drag(const SettlingSphere& sp, double U, double t_end) {
  const double fall = 12;
  const Grid grid(Axis::stretched(StretchedAxis{-5, 5, -0.8, 0.8, sp.h, 1.1, 8}, false),
                  Axis::stretched(StretchedAxis{-5, 5, -0.8, 0.8, sp.h, 1.1, 8}, false),
                  Axis::stretched(StretchedAxis{-4, fall + 4, -0.8, fall + 0.8, sp.h, 1.1, 8}, false));
  Boundaries bc = Boundaries::all(BC::velocity);
  for (auto& f : bc.face) f.velocity = [U](double) { return Vec3(0, 0, -U); };
  bc.face[face(2, 0)] = {BC::outflow, {}, {}};
  SolverOptions opt;
  opt.nu = sp.nu;
  opt.cfl = 0.8;
  opt.dt_max = 0.05 * sp.D / U;
  Solver solver(grid, bc, opt);
  solver.initialise([U](double, double, double) { return Vec3(0, 0, -U); });
  ImmersedBoundary ib(grid, ImmersedOptions{.density = 1.0});
  ib.add_part(sphere_mesh(sp.D / 2, 16), fixed_part(RigidTransform{Mat3::Identity(), Vec3(0, 0, fall / 2)}));
  ib.attach(solver);
  double sum = 0;
  int n = 0;
  while (solver.time() < t_end - 1e-12) {
    solver.step();
    if (solver.time() > 0.75 * t_end) {
      const auto L = sp.exchange ? ib.exchange_loads(solver, Vec3::Zero()) : ib.loads(solver, Vec3::Zero());
      sum -= L[0].force().z(), ++n;
    }
  }
  return sum / n;
}

// Settling sphere, density ratio 10, Re ~ 20, D/8, the insects' default (momentum-exchange) loads (CI).
//  1. The coupling itself: the sphere's equation at its last instant, drag = net weight (s - 1) rho_f V g less
//     (m + rho_f V / 2) dw/dt (dw/dt from the last 2 D/U: the Oseen tail), against the drag the same grid gives a
//     fixed sphere in a uniform stream at the settling sphere's speed relative to the fluid around it (w_end
//     A / (A - A_s): the closed box's return flow through its cross-section A). Tolerance 2 % (a moving and a fixed
//     sphere on D/8 differ by 0.1-0.7 % in the Galilean test; the exchange loads' stage-to-stage noise).
//  2. Against the drag curve: w_end within 8 % of the curve's terminal velocity. The exchange loads over-read the
//     sphere's drag on coarse grids (+4 % at D/12, Re 100), and U ~ C_D^(-0.7) near Re 20; docs/validation.md
//     records the finer grids.
//  Printed, not asserted: w at t = 0.5 D/U against the Basset-Boussinesq-Oseen equation. On D/8 the exchange loads'
//  added mass is about twice the potential-flow value (the force partitioning's accelerated-sphere test), which
//  slows the start; docs/validation.md gives the finer grids.
TEST(FluidBodyCoupling, SettlingSphereReachesTheStandardDragCurveTerminalVelocity) {
  SettlingSphere sp;
  sp.nu = 0.05;
  sp.s = 10;
  sp.exchange = true;
  // FB_H=0.0625 (D/16) etc. runs the converged grids of docs/validation.md; FB_SURFACE=1 the surface loads.
  if (const char* e = std::getenv("FB_H")) sp.h = std::atof(e);
  if (std::getenv("FB_SURFACE")) sp.exchange = false;
  sp.g = 0.75 * standard_drag(20) / (sp.s - 1);  // the curve's terminal velocity 1 at Re = 20
  const double U = terminal_velocity(sp.D, sp.s, sp.g, sp.nu);
  ASSERT_NEAR(U, 1.0, 1e-6);
  const auto t0 = std::chrono::steady_clock::now();
  const double t_end = 24;
  const auto r = sp.run(t_end, t_end - 1);
  ASSERT_FALSE(r.empty());
  double w_half = 0;
  for (const auto& q : r)
    if (q.t <= 0.5 + 1e-9) w_half = q.w;
  const double w_bbo = bbo_velocity(sp.D, sp.s, sp.g, sp.nu, 0.5);
  const double w_end = r.back().w;
  double w_before = 0;
  for (const auto& q : r)
    if (q.t <= r.back().t - 2) w_before = q.w;
  const double t_run = seconds_since(t0);
  const double V = pi / 6, A = 100, As = pi / 4;  // the box's cross-section: 10 x 10 D
  const double dwdt = (w_end - w_before) / (r.back().t - (r.back().t - 2));
  const double need = (sp.s - 1) * V * sp.g - (sp.s + 0.5) * V * dwdt;
  const double u_rel = w_end * A / (A - As);
  const double drag = fixed_sphere_drag(sp, u_rel, 12.0);
  std::printf("  settling sphere (s = %.1f, Re_t %.1f by the curve, D/%.0f, %s loads): w(0.5) %.5f vs BBO %.5f (%+.2f %%); "
              "w(t = %.2f) = %.4f vs the curve's %.4f (%+.2f %%), 2 D/U earlier %.4f; fixed sphere at U = %.4f: drag "
              "%.4f vs the settling sphere's %.4f (%+.2f %%); %zu steps, %.1f s + %.1f s\n",
              sp.s, U * sp.D / sp.nu, sp.D / sp.h, sp.exchange ? "exchange" : "surface", w_half, w_bbo,
              100 * (w_half / w_bbo - 1), r.back().t, w_end, U, 100 * (w_end / U - 1), w_before, u_rel, drag, need,
              100 * (drag / need - 1), r.size(), t_run, seconds_since(t0) - t_run);
  EXPECT_NEAR(drag / need, 1.0, 0.02);
  EXPECT_NEAR(w_end / U, 1.0, 0.08);
  // Energy: the net weight's work goes into the body's kinetic energy, the fluid's and the viscous dissipation;
  // what is left is the work of the forcing that no load accounts for (the exchange loads' lag, the forcing's own
  // dissipation at the surface) and the time error. The fluid the forcing holds inside the sphere moves with it:
  // its kinetic energy rho V w^2 / 2 is reported apart.
  const auto& e = r.back();
  const double inside = 0.5 * V * e.w * e.w;
  const double rest = e.work - e.body - e.fluid - e.dissipated;
  std::printf("  energy at t = %.2f: weight's work %.5f = body %.5f (%.2f %%) + fluid %.5f (%.2f %%, of which inside "
              "the sphere %.5f) + dissipated %.5f (%.2f %%) + unaccounted %+.5f (%+.2f %%)\n",
              e.t, e.work, e.body, 100 * e.body / e.work, e.fluid, 100 * e.fluid / e.work, inside, e.dissipated,
              100 * e.dissipated / e.work, rest, 100 * rest / e.work);
  // What the resolved terms leave unaccounted (docs/validation.md): at t = 4 D/U +0.2 % of the work on D/8 and
  // -2.2 % on D/12 (tolerance 3 %: the coupling neither creates nor loses energy beyond that while the wake is
  // young); by t = 24 the forcing has removed +10.7 % (D/8) and +6.2 % (D/12) of it at the under-resolved surface,
  // shrinking with the grid (tolerance on D/8: between 0 and 15 %; energy never appears from nowhere).
  double early = 0, early_work = 0;
  for (const auto& q : r)
    if (q.t <= 4 + 1e-9) early = q.work - q.body - q.fluid - q.dissipated, early_work = q.work;
  EXPECT_LT(std::abs(early), 0.03 * early_work);
  EXPECT_GT(rest, 0.0);
  if (sp.h >= 0.125) {
    EXPECT_LT(rest, 0.15 * e.work);
  }
  for (const auto& q : r)
    if (std::abs(q.t - std::round(q.t / 4) * 4) < 0.5 * (r[1].t - r[0].t))
      std::printf("    t %.2f: work %.5f body %.5f fluid %.5f dissipated %.5f unaccounted %+.5f (%+.2f %%)\n", q.t, q.work,
                  q.body, q.fluid, q.dissipated, q.work - q.body - q.fluid - q.dissipated,
                  q.work > 0 ? 100 * (q.work - q.body - q.fluid - q.dissipated) / q.work : 0.0);
}

// A neutrally buoyant sphere released in fluid at rest: no net weight, no flow, no motion. A sanity check, weak by
// nature: with everything at rest the forcing and the loads are exactly zero, so it fails only if the coupling or the
// forcing of a body at rest in fluid at rest creates a load (the settling sphere is the real test). Tolerance 1e-12.
TEST(FluidBodyCoupling, NeutrallyBuoyantSphereStaysAtRest) {
  SettlingSphere sp;
  sp.s = 1.0;
  sp.g = 1.0;
  sp.h = 0.25;
  const auto r = sp.run(1.0, 1.0);
  double wmax = 0;
  for (const auto& q : r) wmax = std::max(wmax, std::abs(q.w));
  std::printf("  neutrally buoyant sphere: max |w| %.2e over %zu steps\n", wmax, r.size());
  EXPECT_LT(wmax, 1e-12);
}

}  // namespace

namespace {

using namespace flapstab;
using namespace flapstab::ns;

// Angular velocity (in the frame the rotation maps to) of R(t) by central differences: skew(w) = R' R^T.
Vec3 angular_velocity(const std::function<Mat3(double)>& R, double t, double h) {
  const Mat3 W = (R(t + h) - R(t - h)) / (2 * h) * R(t).transpose();
  return Vec3(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1)) / 2;
}

// part_in_grid composes the body's motion with a part's motion relative to the body: its velocity, angular velocity
// and accelerations must be the time derivatives of the composed pose. Checked against central differences of an
// analytic body trajectory (all six degrees of freedom moving) carrying a part that rotates and translates relative
// to the body. Tolerance 1e-6 of each quantity's scale (differences of step 1e-4: error ~1e-8).
TEST(FreeBody, PartInGridIsTheDerivativeOfTheComposedPose) {
  const double h = 1e-4;
  auto body = [](double t) {  // body state (position, Euler angles); velocities from differences below
    BodyStateVector x = BodyStateVector::Zero();
    x.segment<3>(0) = Vec3(0.3 * std::sin(2 * t), 0.1 * t * t, -0.2 * std::cos(t));
    x(9) = 0.3 * std::sin(t);
    x(10) = 0.2 + 0.4 * std::sin(1.7 * t);
    x(11) = -0.5 * std::cos(0.9 * t);
    return x;
  };
  auto Rb = [&](double t) { const BodyStateVector x = body(t); return euler321(x(9), x(10), x(11)); };
  auto state = [&](double t) {  // full state: body-axes velocity and rates from differences
    BodyStateVector x = body(t);
    const Vec3 Xdot = (body(t + h).segment<3>(0) - body(t - h).segment<3>(0)) / (2 * h);
    x.segment<3>(3) = Rb(t).transpose() * Xdot;
    x.segment<3>(6) = Rb(t).transpose() * angular_velocity(Rb, t, h);
    return x;
  };
  auto Rr = [](double t) { return Mat3(rot_z(0.8 * t) * rot_x(std::sin(1.3 * t))); };
  auto cr = [](double t) { return Vec3(0.02 + 0.01 * std::sin(3 * t), 0.05 * std::cos(2 * t), 0.01 * t); };
  auto relative = [&](double t) {  // the part's kinematics relative to the body, body axes
    PartState p;
    p.pose = RigidTransform{Rr(t), cr(t)};
    p.velocity.centre = cr(t);
    p.velocity.velocity = (cr(t + h) - cr(t - h)) / (2 * h);
    p.velocity.omega = angular_velocity(Rr, t, h);
    p.acceleration = (cr(t + h) - 2 * cr(t) + cr(t - h)) / (h * h);
    p.angular_acceleration = (angular_velocity(Rr, t + h, h) - angular_velocity(Rr, t - h, h)) / (2 * h);
    return p;
  };
  auto composed = [&](double t) {
    const BodyStateVector x = state(t);
    BodyStateVector dx = (state(t + h) - state(t - h)) / (2 * h);
    return part_in_grid(body_frame(x, dx), relative(t));
  };
  const double t = 0.7;
  const PartState s = composed(t);
  const Vec3 v_fd = (composed(t + h).pose.translation - composed(t - h).pose.translation) / (2 * h);
  const Vec3 w_fd = angular_velocity([&](double u) { return composed(u).pose.rotation; }, t, h);
  const Vec3 a_fd = (composed(t + h).velocity.velocity - composed(t - h).velocity.velocity) / (2 * h);
  const Vec3 al_fd = (composed(t + h).velocity.omega - composed(t - h).velocity.omega) / (2 * h);
  EXPECT_LT((s.velocity.centre - s.pose.translation).norm(), 1e-14);
  EXPECT_LT((s.velocity.velocity - v_fd).norm(), 1e-6 * v_fd.norm());
  EXPECT_LT((s.velocity.omega - w_fd).norm(), 1e-6 * w_fd.norm());
  EXPECT_LT((s.acceleration - a_fd).norm(), 1e-5 * a_fd.norm());
  EXPECT_LT((s.angular_acceleration - al_fd).norm(), 1e-5 * al_fd.norm());
  std::printf("  composed part: |v| %.4f (difference %.1e), |w| %.4f (%.1e), |a| %.4f (%.1e), |alpha| %.4f (%.1e)\n",
              v_fd.norm(), (s.velocity.velocity - v_fd).norm(), w_fd.norm(), (s.velocity.omega - w_fd).norm(),
              a_fd.norm(), (s.acceleration - a_fd).norm(), al_fd.norm(), (s.angular_acceleration - al_fd).norm());
}

// The wrench moved to the body: a force through the body's origin O has no moment about O, and the body-axes
// components are the grid's rotated back.
TEST(FreeBody, WrenchOnBodyIsAboutOInBodyAxes) {
  BodyStateVector x = BodyStateVector::Zero();
  x.segment<3>(0) = Vec3(1, -2, 0.5);
  x(9) = 0.3, x(10) = -0.4, x(11) = 1.1;
  const BodyFrame b = body_frame(x, BodyStateVector::Zero());
  const Vec3 F(0.2, -1, 3), O = x.segment<3>(0);
  const Wrench w = wrench_on_body(b, F, O.cross(F));  // moment about the grid origin of F acting at O
  EXPECT_LT(w.moment.norm(), 1e-14);
  EXPECT_LT((b.rotation * w.force - F).norm(), 1e-14);
}

}  // namespace

#include "cfd/navier_stokes/insect_motion.hpp"
#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "common/case_text.hpp"
#include "flight/cfd_flight.hpp"
#include "cfd/aero_factory.hpp"
#include "core/configuration.hpp"
#include "trim/parameters.hpp"
#include "trim/refine.hpp"
#include "trim/trim.hpp"

namespace {

using namespace flapstab;

// The test moth on a tiny grid (4 cells per mean chord), a gentle wingbeat at Re = 20, 60 steps per wingbeat (the
// CFD model tests' case): a wingbeat costs about a second.
Case tiny_case(const std::string& name, const std::string& extra = {}) {
  const std::string keys =
      "cells_per_chord = 4\nfine_margin_R = 0.4\nupstream_R = 0\ndownstream_R = 0\nlateral_R = 0\nabove_R = 0\n"
      "below_R = 0.5\nsteps_per_cycle = 60\nbody_divisions = 6\nwing_span_stations = 12\nwing_chord_divisions = 4\n"
      "threads = 1\nreynolds = 20\n" + extra;
  std::string text = flapstab::testing::replace(flapstab::testing::valid_cfd_case_text(), "[trim]\n", "[aero.cfd]\n" + keys + "\n[trim]\n");
  text = flapstab::testing::replace(flapstab::testing::replace(text, "cos_deg = [-60.0]", "cos_deg = [-10.0]"), "sin_deg = [-55.0]",
                          "sin_deg = [-10.0]");
  return load_case(flapstab::testing::write_temp(name, text));
}

// With a body too heavy to move (the body's mass and inertia x 1e15, the wings' unchanged, no gravity) the coupled
// run is the prescribed one: the parts composed with a body at rest are the prescribed parts (to 1e-16 relative),
// so the loads agree over half a wingbeat to the level at which such a difference moves the Poisson solver's
// stopping iteration (measured 3e-10 of the largest force; tolerance 1e-8). A wrong composition differs at order one.
TEST(CfdFlight, ImmovableBodyGivesThePrescribedRun) {
  Case c = tiny_case("cfd_flight_heavy.toml");
  c.insect.body.mass *= 1e15;
  c.insect.body.inertia *= 1e15;
  const ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  const ns::CfdModel unused(c, nullptr);
  const FlightDynamics dyn(unused, c.insect, c.kinematics, {}, DofSet::six_dof, 0.0, false, c.path);
  CfdFlight fl(c, dyn, plan);
  fl.start(nullptr, BodyStateVector::Zero());
  ns::Simulation ref(c, c.kinematics, BodyMotion{}, plan);
  double worst = 0, scale = 0;
  for (int k = 0; k < 30; ++k) {
    const CfdFlightStep s = fl.advance();
    const Wrench w = ref.advance().row.total();
    worst = std::max(worst, (s.aero.force - w.force).norm());
    scale = std::max(scale, w.force.norm());
  }
  std::printf("  immovable body: |F - F_prescribed| %.2e of max |F| %.3e; |x| %.1e\n", worst / scale, scale,
              fl.current().x.norm());
  EXPECT_LT(worst, 1e-8 * scale);
  EXPECT_LT(fl.current().x.norm(), 1e-12);
}

// A checkpoint (the flow state, the body state and the wrench held over the next step) continues a coupled run bit
// for bit: 20 steps straight, and 10 + restore + 10.
TEST(CfdFlight, RestartContinuesBitForBit) {
  const Case c = tiny_case("cfd_flight_restart.toml");
  const ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  const ns::CfdModel unused(c, nullptr);
  const FlightDynamics dyn(unused, c.insect, c.kinematics, {}, DofSet::longitudinal, std::nullopt, false, c.path);
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(7) = 2.0;  // q, rad/s
  CfdFlight a(c, dyn, plan);
  a.start(nullptr, x0);
  for (int k = 0; k < 20; ++k) a.advance();
  CfdFlight b(c, dyn, plan);
  b.start(nullptr, x0);
  for (int k = 0; k < 10; ++k) b.advance();
  const ns::SimulationState s = b.flow_state();
  const BodyStateVector xb = b.current().x;
  const Wrench held = b.current().aero;
  CfdFlight r(c, dyn, plan);
  r.restore(s, xb, held);
  for (int k = 0; k < 10; ++k) r.advance();
  std::printf("  restart: theta %.17g straight, %.17g continued; Z %.17g, %.17g\n", a.current().x(10),
              r.current().x(10), a.current().aero.force.z(), r.current().aero.force.z());
  EXPECT_GT(std::abs(a.current().x(10)), 1e-4);  // the body did move
  for (int i = 0; i < 12; ++i) EXPECT_EQ(a.current().x(i), r.current().x(i)) << i;
  EXPECT_EQ(a.current().aero.force.z(), r.current().aero.force.z());
  EXPECT_EQ(a.current().aero.moment.y(), r.current().aero.moment.y());
}

// The fluid the forcing holds solid (the explicit coupling's lag bound): the body's ellipsoid volume pi/6 L W H
// and two wing slabs R c 2 (0.6 h), times the fluid density. Tolerance 5 % (the meshes' discretisation of the
// ellipsoid and the planform). And it is far below the insect's mass (the coupling's stability condition).
TEST(CfdFlight, ForcedFluidMassIsTheBodyAndTheWingSlabs) {
  const Case c = tiny_case("cfd_flight_forced.toml");
  const ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  const ns::CfdModel unused(c, nullptr);
  const FlightDynamics dyn(unused, c.insect, c.kinematics, {}, DofSet::longitudinal, std::nullopt, false, c.path);
  const CfdFlight fl(c, dyn, plan);
  const Body& b = c.insect.body;
  const double body = pi / 6 * b.length * b.width * b.height;
  const double wings = 2 * c.insect.wing.length * c.insect.wing.mean_chord * 2 * 0.6 * plan.h_actual;
  const double expected = plan.rho * (body + wings);
  std::printf("  forced fluid mass %.4e kg (expected %.4e: body %.3e, wings %.3e m^3), %.4f of the insect's mass\n",
              fl.forced_fluid_mass(), expected, body, wings, fl.forced_fluid_mass() / fl.body_mass());
  EXPECT_NEAR(fl.forced_fluid_mass() / expected, 1.0, 0.05);
  EXPECT_LT(fl.forced_fluid_mass() / fl.body_mass(), 0.1);
}

// A body that leaves the uniform fine box stops the run with BodyLeftGrid naming the part and the key that gives
// more room; the state is the offending step's (a driver writes its checkpoint).
TEST(CfdFlight, BodyLeavingTheFineBoxStopsWithAClearMessage) {
  const Case c = tiny_case("cfd_flight_leave.toml");
  const ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  const ns::CfdModel unused(c, nullptr);
  const FlightDynamics dyn(unused, c.insect, c.kinematics, {}, DofSet::translation, std::nullopt, false, c.path);
  // Placed just inside the box's forward margin, moving forward at 0.3 of the mean wingtip speed: out within
  // a wingbeat.
  const double room = plan.fine_hi.x() - plan.swept_hi.x();
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(0) = 0.9 * room;
  x0(3) = 0.3 * plan.u_ref;
  CfdFlight fl(c, dyn, plan);
  fl.start(nullptr, x0);
  std::string what;
  long steps = 0;
  try {
    for (; steps < 60; ++steps) fl.advance();  // a wingbeat
  } catch (const BodyLeftGrid& e) {
    what = e.what();
  }
  std::printf("  left the box after %ld steps: %s\n", steps, what.c_str());
  ASSERT_FALSE(what.empty());
  EXPECT_LT(steps, 60);
  EXPECT_NE(what.find("fine_margin_R"), std::string::npos);
  EXPECT_NE(what.find("left the grid's uniform fine box"), std::string::npos);
}

// The same body with re-planning: the fine box follows it (each re-plan when a part came within half the room of a
// face, each new box on the first one's lattice holding every part with at least the room), and the flow carried
// over keeps the loads on course: the force changes across the re-plan's step by at most twice its largest change
// per step before it (measured 2026-12-06: 5.7e-3 N against 5.3e-3 N, ratio 1.06; the far field moves with the box,
// so it is not zero). A flow dropped at the re-plan (still air around the moving wings) changed it by 0.28 N, 53 times.
struct ReplanRig {
  Case c = tiny_case("cfd_flight_replan.toml");
  ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  ns::CfdModel unused{c, nullptr};
  FlightDynamics dyn{unused, c.insect, c.kinematics, {}, DofSet::translation, std::nullopt, false, c.path};
  BodyStateVector x0 = BodyStateVector::Zero();
  ReplanRig() {
    x0(0) = 0.4 * (plan.fine_hi.x() - plan.swept_hi.x());  // forward, moving forward at 0.3 of the mean tip speed
    x0(3) = 0.3 * plan.u_ref;
  }
};

TEST(CfdFlight, BodyLeavingTheFineBoxIsFollowedByTheReplannedBox) {
  const ReplanRig rig;
  CfdFlight fl(rig.c, rig.dyn, rig.plan);
  fl.set_replanning(true);
  fl.start(nullptr, rig.x0);
  std::vector<Vec3> f{fl.current().aero.force};
  for (int k = 0; k < 60; ++k) f.push_back(fl.advance().aero.force);  // a wingbeat: no BodyLeftGrid
  const auto& rp = fl.replans();
  ASSERT_GE(rp.size(), 1u);
  // The force's change over the step across the first re-plan against its largest change per step before it, after
  // the impulsive start from rest.
  const long k = rp.front().step;  // F(k) on the old grid, F(k + 1) on the new one
  double across = (f[std::size_t(k) + 1] - f[std::size_t(k)]).norm(), before = 0, scale = 0;
  for (long n = 6; n < k; ++n) before = std::max(before, (f[std::size_t(n) + 1] - f[std::size_t(n)]).norm());
  for (const Vec3& v : f) scale = std::max(scale, v.norm());
  std::printf("  %zu re-plan(s), the first at step %ld (gap %.3g mm, room %.3g mm); box x [%.4g, %.4g] m, first "
              "[%.4g, %.4g]; |F| changes by %.3e across it, by at most %.3e per step before it (max |F| %.3e)\n",
              rp.size(), rp.front().step, 1e3 * rp.front().gap, 1e3 * fl.room(), fl.plan().fine_lo.x(),
              fl.plan().fine_hi.x(), rig.plan.fine_lo.x(), rig.plan.fine_hi.x(), across, before, scale);
  EXPECT_NEAR(fl.room(), 0.4 * rig.c.insect.wing.length, 1e-12);
  for (const CfdReplan& r : rp) {
    EXPECT_LT(r.gap, 0.5 * fl.room());
    EXPECT_GT(r.gap, 0.0);
    EXPECT_GT(r.shift.hi[0], 0);  // forward
  }
  EXPECT_GT(fl.plan().fine_hi.x(), rig.plan.fine_hi.x());
  for (int i = 0; i < fl.simulation().part_count(); ++i) {
    const ns::BoundingBox bb = fl.simulation().surface(i).bounding_box();
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(bb.lo(a) - fl.plan().fine_lo(a), 0.5 * fl.room());
      EXPECT_GE(fl.plan().fine_hi(a) - bb.hi(a), 0.5 * fl.room());
    }
  }
  EXPECT_LT(across, 2 * before);
}

// A checkpoint taken after a re-plan (the flow on the new grid, its shift) continues the flight bit for bit.
TEST(CfdFlight, RestartAfterAReplanContinuesBitForBit) {
  const ReplanRig rig;
  CfdFlight a(rig.c, rig.dyn, rig.plan);
  a.set_replanning(true);
  a.start(nullptr, rig.x0);
  for (int k = 0; k < 30; ++k) a.advance();
  ASSERT_GE(a.replans().size(), 1u);
  const long cut = a.replans().front().step + 3;
  ASSERT_LT(cut, 30);
  CfdFlight b(rig.c, rig.dyn, rig.plan);
  b.set_replanning(true);
  b.start(nullptr, rig.x0);
  while (b.current().step < cut) b.advance();
  CfdFlight r(rig.c, rig.dyn, rig.plan);
  r.set_replanning(true);
  r.restore(b.flow_state(), b.current().x, b.current().aero, {}, b.fine_box_shift());
  while (r.current().step < 30) r.advance();
  std::printf("  restart at step %ld after a re-plan at step %ld: x %.17g straight, %.17g continued\n", cut,
              a.replans().front().step, a.current().x(0), r.current().x(0));
  EXPECT_EQ(r.fine_box_shift(), a.fine_box_shift());
  for (int i = 0; i < 12; ++i) EXPECT_EQ(a.current().x(i), r.current().x(i)) << i;
  EXPECT_EQ(a.current().aero.force.x(), r.current().aero.force.x());
  EXPECT_EQ(a.current().aero.force.z(), r.current().aero.force.z());
}

// The tiny moth with the stroke plane as the dynamics' one actuator, and a controller on it (unbounded); `heavy`
// makes the body immovable (mass and inertia x 1e15, no gravity, six degrees of freedom).
struct StrokePlaneRig {
  Case c;
  ns::CfdPlan plan;
  std::unique_ptr<ns::CfdModel> unused;
  std::unique_ptr<FlightDynamics> dyn;
  double dt = 0;  // the fluid step: 60 per wingbeat
  explicit StrokePlaneRig(const std::string& name, bool heavy = false, const std::string& actuator = "stroke_plane_deg")
      : c(tiny_case(name)) {
    if (heavy) {
      c.insect.body.mass *= 1e15;
      c.insect.body.inertia *= 1e15;
    }
    plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
    unused = std::make_unique<ns::CfdModel>(c, nullptr);
    dyn = std::make_unique<FlightDynamics>(*unused, c.insect, c.kinematics,
                                           std::vector<TrimParameterSpec>{unbounded_parameter(actuator)},
                                           heavy ? DofSet::six_dof : DofSet::longitudinal,
                                           heavy ? std::optional<double>(0.0) : std::nullopt, false, c.path);
    dt = c.kinematics.period() / 60;
  }
  static ControllerSpec controller(std::vector<FeedbackTerm> terms, ControlUpdate update = ControlUpdate::continuous) {
    ControllerSpec ctrl;
    ctrl.actuators = {unbounded_parameter(terms.empty() ? std::string("stroke_plane_deg") : terms.front().actuator)};
    ctrl.terms = std::move(terms);
    ctrl.update = update;
    return ctrl;
  }
  std::unique_ptr<CfdFlight> flight(const ControllerSpec& ctrl, std::function<BodyStateVector(double)> reference) const {
    auto fl = std::make_unique<CfdFlight>(c, *dyn, plan);
    fl->set_controller(ctrl, std::move(reference));
    return fl;
  }
  // Flies `a` 20 steps from x0 and `b` 10, restores `r` from b's state with its past steps and its wings' phase, and
  // flies r 10 more: an exact continuation leaves r equal to a.
  static void fly_split(CfdFlight& a, CfdFlight& b, CfdFlight& r, const BodyStateVector& x0) {
    a.start(nullptr, x0);
    for (int k = 0; k < 20; ++k) a.advance();
    b.start(nullptr, x0);
    std::vector<CfdFlightStep> past{b.current()};
    for (int k = 0; k < 10; ++k) past.push_back(b.advance());
    r.restore(b.flow_state(), b.current().x, b.current().aero, past, {}, b.current().phase);
    for (int k = 0; k < 10; ++k) r.advance();
  }
};
const auto no_deviation = [](double) { return BodyStateVector::Zero().eval(); };

// Closed loop: a term's command is minus its gain times the sensed deviation a latency ago, the history linear
// between the fluid steps and zero before the start (the body state minus the reference, here the tethered hover).
// Latency 2.5 steps on theta: the mean of the deviations 2 and 3 steps back; no latency on q: the current state.
// Exact up to rounding of the interpolation weights (tolerance 1e-12 of the command's scale).
TEST(CfdFlight, DelayedCommandIsTheDeviationALatencyAgo) {
  const StrokePlaneRig rig("cfd_flight_delay.toml");
  const double dt = rig.dt, g_theta = 30, g_q = 0.2;  // deg per rad, deg per rad/s
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(7) = 2.0;   // q, rad/s
  x0(10) = 0.01;  // theta, rad
  const auto flp = rig.flight(
      StrokePlaneRig::controller({{"theta", "stroke_plane_deg", g_theta, 2.5 * dt, 0}, {"q", "stroke_plane_deg", g_q, 0, 0}}),
      no_deviation);
  CfdFlight& fl = *flp;
  fl.start(nullptr, x0);
  std::vector<CfdFlightStep> st{fl.current()};
  for (int k = 0; k < 12; ++k) st.push_back(fl.advance());
  double worst = 0;
  for (std::size_t n = 0; n < st.size(); ++n) {
    const double sensed = n < 3 ? 0.0 : 0.5 * (st[n - 3].x(10) + st[n - 2].x(10));
    const double expected = -g_theta * sensed - g_q * st[n].x(7);
    ASSERT_EQ(st[n].command.size(), 1u);
    worst = std::max(worst, std::abs(st[n].command[0] - expected));
  }
  std::printf("  delayed command: largest error %.2e deg (command at step 0 %.4f deg, step 12 %.4f deg)\n", worst,
              st[0].command[0], st.back().command[0]);
  EXPECT_LT(worst, 1e-12 * (g_theta * 0.01 + g_q * 2.0));
  EXPECT_GT(std::abs(st.back().x(10) - st[0].x(10)), 1e-4);  // theta did change
}

// Sampled once per wingbeat (update = "wingbeat"): the command holds over each wingbeat and is the law's value at
// the wingbeat's start (latency 2 steps on theta, none on q).
TEST(CfdFlight, WingbeatUpdateHoldsTheStartOfWingbeatCommand) {
  const StrokePlaneRig rig("cfd_flight_hold.toml");
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(7) = 2.0;
  const auto flp = rig.flight(StrokePlaneRig::controller({{"theta", "stroke_plane_deg", 30, 2 * rig.dt, 0},
                                                          {"q", "stroke_plane_deg", 0.2, 0, 0}},
                                                         ControlUpdate::wingbeat),
                              no_deviation);
  CfdFlight& fl = *flp;
  fl.start(nullptr, x0);
  std::vector<CfdFlightStep> st{fl.current()};
  for (int k = 0; k < 63; ++k) st.push_back(fl.advance());
  for (std::size_t n = 1; n < 60; ++n) EXPECT_EQ(st[n].command[0], st[0].command[0]) << n;
  EXPECT_NEAR(st[0].command[0], -0.2 * 2.0, 1e-15);
  const double at60 = -30 * st[58].x(10) - 0.2 * st[60].x(7);
  std::printf("  held command: %.6f deg over wingbeat 1, %.6f deg from wingbeat 2 (law %.6f)\n", st[0].command[0],
              st[60].command[0], at60);
  EXPECT_NEAR(st[60].command[0], at60, 1e-12 * std::abs(at60));
  for (std::size_t n = 61; n < st.size(); ++n) EXPECT_EQ(st[n].command[0], st[60].command[0]) << n;
  EXPECT_NE(st[60].command[0], st[0].command[0]);
}

// The command moves the immersed wings: with the body held (mass x 1e15, no gravity) and a constant command delta
// on the stroke plane (a constant sensed deviation against a shifted reference), each wing's pose in the grid is the
// trimmed one turned by rot_y(delta) about its hinge (the stroke plane's rotation, core/configuration), the hinge
// and the body unmoved (O stays where the trimmed kinematics put it); its angular velocity turns with it.
TEST(CfdFlight, CommandTiltsTheImmersedStrokePlane) {
  const StrokePlaneRig rig("cfd_flight_tilt.toml", true);
  BodyStateVector shifted = BodyStateVector::Zero();
  shifted(10) = -0.05;  // the sensed deviation +0.05 rad: command -5 deg
  const auto flp = rig.flight(StrokePlaneRig::controller({{"theta", "stroke_plane_deg", 100, 0, 0}}),  // deg per rad
                              [shifted](double) { return shifted; });
  CfdFlight& fl = *flp;
  fl.start(nullptr, BodyStateVector::Zero());
  const Mat3 tilt = rot_y(-5 * pi / 180);
  double worst_r = 0, worst_t = 0, worst_w = 0;
  for (int k = 0; k < 6; ++k) {
    const CfdFlightStep s = fl.advance();
    EXPECT_NEAR(s.command[0], -5.0, 1e-9);
    const auto now = fl.simulation().part_states(), trim = fl.simulation().prescribed_parts(s.time);
    ASSERT_EQ(now.size(), trim.size());
    for (std::size_t i = 0; i < now.size(); ++i) {
      const Mat3 expected = i == 0 ? Mat3::Identity() : tilt;
      worst_r = std::max(worst_r, (now[i].pose.rotation * trim[i].pose.rotation.transpose() - expected).norm());
      worst_t = std::max(worst_t, (now[i].pose.translation - trim[i].pose.translation).norm());
      worst_w = std::max(worst_w, (now[i].velocity.omega - expected * trim[i].velocity.omega).norm());
    }
  }
  std::printf("  tilted stroke plane: rotation %.1e, hinge %.1e m, angular velocity %.1e rad/s off\n", worst_r,
              worst_t, worst_w);
  EXPECT_LT(worst_r, 1e-10);
  EXPECT_LT(worst_t, 1e-10 * rig.c.insect.wing.length);
  EXPECT_LT(worst_w, 1e-8);
}

// The same with the mean stroke angle as the actuator (the pitch lever of a shifted lift centre): a constant command
// delta shifts each wing's stroke angle phi by delta, i.e. turns the wing about the stroke-plane normal through its
// hinge. With R = R_sp Rz(-phi) ... (core/configuration) the right wing's pose is the trimmed one turned by
// R_sp Rz(-delta) R_sp^T, the left (mirror image) by R_sp Rz(+delta) R_sp^T; hinges and body unmoved; the angular
// velocity turns with the pose; a command of -5 deg moves the right wing's tip towards the tail (-x).
TEST(CfdFlight, CommandShiftsTheImmersedMeanStroke) {
  const StrokePlaneRig rig("cfd_flight_shift.toml", true, "stroke_mean_deg");
  BodyStateVector shifted = BodyStateVector::Zero();
  shifted(10) = -0.05;  // the sensed deviation +0.05 rad: command -5 deg
  const auto flp = rig.flight(StrokePlaneRig::controller({{"theta", "stroke_mean_deg", 100, 0, 0}}),  // deg per rad
                              [shifted](double) { return shifted; });
  CfdFlight& fl = *flp;
  fl.start(nullptr, BodyStateVector::Zero());
  const double delta = -5 * pi / 180;
  const Mat3 sp = rot_y(rig.c.kinematics.stroke_plane_in_stability());
  const Mat3 turn_right = sp * rot_z(-delta) * sp.transpose(), turn_left = sp * rot_z(delta) * sp.transpose();
  double worst_r = 0, worst_t = 0, worst_w = 0, tip_dx = 0;
  for (int k = 0; k < 6; ++k) {
    const CfdFlightStep s = fl.advance();
    EXPECT_NEAR(s.command[0], -5.0, 1e-9);
    const auto now = fl.simulation().part_states(), trim = fl.simulation().prescribed_parts(s.time);
    ASSERT_EQ(now.size(), 3u);
    for (std::size_t i = 0; i < now.size(); ++i) {
      const bool right = trim[i].pose.translation.y() > 0;
      const Mat3 expected = i == 0 ? Mat3::Identity() : right ? turn_right : turn_left;
      worst_r = std::max(worst_r, (now[i].pose.rotation * trim[i].pose.rotation.transpose() - expected).norm());
      worst_t = std::max(worst_t, (now[i].pose.translation - trim[i].pose.translation).norm());
      worst_w = std::max(worst_w, (now[i].velocity.omega - expected * trim[i].velocity.omega).norm());
      if (i != 0 && right) {  // the wing's span axis (y of its frame) carries the tip
        const Vec3 tip_now = now[i].pose.rotation * Vec3::UnitY(), tip_trim = trim[i].pose.rotation * Vec3::UnitY();
        tip_dx += (tip_now - tip_trim).x() / 6;
      }
    }
  }
  std::printf("  shifted mean stroke: rotation %.1e, hinge %.1e m, angular velocity %.1e rad/s off; right tip moves "
              "%+.4f R along x\n",
              worst_r, worst_t, worst_w, tip_dx);
  EXPECT_LT(worst_r, 1e-10);
  EXPECT_LT(worst_t, 1e-10 * rig.c.insect.wing.length);
  EXPECT_LT(worst_w, 1e-8);
  EXPECT_LT(tip_dx, -0.01);  // towards the tail
}

// A closed-loop flight continues bit for bit from a checkpoint: the sensed history (a latency of 3.4 steps) and a
// sensor filter are rebuilt from the flight's past steps.
TEST(CfdFlight, ClosedLoopRestartContinuesBitForBit) {
  const StrokePlaneRig rig("cfd_flight_restart_cl.toml");
  const ControllerSpec ctrl = StrokePlaneRig::controller(
      {{"theta", "stroke_plane_deg", 30, 3.4 * rig.dt, 2 * rig.dt}, {"q", "stroke_plane_deg", 0.2, 3.4 * rig.dt, 0}});
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(7) = 2.0;
  const auto ap = rig.flight(ctrl, no_deviation), bp = rig.flight(ctrl, no_deviation), rp = rig.flight(ctrl, no_deviation);
  CfdFlight &a = *ap, &b = *bp, &r = *rp;
  StrokePlaneRig::fly_split(a, b, r, x0);
  std::printf("  closed-loop restart: theta %.17g straight, %.17g continued; command %.17g, %.17g\n",
              a.current().x(10), r.current().x(10), a.current().command[0], r.current().command[0]);
  EXPECT_GT(std::abs(a.current().command[0]), 1e-3);  // the loop did act
  for (int i = 0; i < 12; ++i) EXPECT_EQ(a.current().x(i), r.current().x(i)) << i;
  EXPECT_EQ(a.current().command[0], r.current().command[0]);
  EXPECT_EQ(a.current().aero.force.z(), r.current().aero.force.z());
  // Without its past a closed-loop flight cannot continue.
  EXPECT_THROW(rig.flight(ctrl, no_deviation)->restore(b.flow_state(), b.current().x, b.current().aero), SolveError);
}

// The wingbeat frequency as an actuator: the wings' phase is integrated with the body. An immovable body at O whose
// sensors see a constant pitch deviation (the reference pitched by -theta0) after a latency of 10.1 steps: the
// frequency is the trimmed one until then and f_trim + u after, so the phase is f_trim L + (f_trim + u)(t - L) (the
// Runge-Kutta sub-step that holds the jump errs by at most u dt / 6, reached with the jump at its midpoint: the
// tolerance), where the flow time as the
// kinematic time (the earlier treatment) would put it at (f_trim + u) t, u L further. The immersed parts are the
// commanded kinematics' at kinematic time phase / (f_trim + u) (to rounding).
TEST(CfdFlight, FrequencyCommandAdvancesTheWingsPhase) {
  const StrokePlaneRig rig("cfd_flight_frequency.toml", true, "frequency_hz");
  const double dt = rig.dt, L = 10.1 * dt, theta0 = 0.05, gain = 40;  // Hz per rad: u = -2 Hz
  const ControllerSpec ctrl = StrokePlaneRig::controller({{"theta", "frequency_hz", gain, L, 0}});
  BodyStateVector ref = BodyStateVector::Zero();
  ref(10) = -theta0;
  const auto fl = rig.flight(ctrl, [ref](double) { return ref; });
  fl->start(nullptr, BodyStateVector::Zero());
  for (int k = 0; k < 30; ++k) fl->advance();
  const double f0 = rig.c.kinematics.frequency_hz, u = -gain * theta0, t = fl->current().time;
  const double expected = f0 * L + (f0 + u) * (t - L), phase = fl->current().phase;
  ASSERT_EQ(fl->current().command.size(), 1u);
  EXPECT_NEAR(fl->current().command[0], u, 1e-9);
  std::printf("  frequency command %.3f Hz after %.2f steps: phase %.12f, expected %.12f (flow time x f: %.12f)\n", u,
              L / dt, phase, expected, (f0 + u) * t);
  EXPECT_NEAR(phase, expected, std::abs(u) * dt / 6);
  EXPECT_GT(std::abs(phase - (f0 + u) * t), 20 * std::abs(u) * dt / 6);
  // The parts: the commanded kinematics at kinematic time phase / (f0 + u), the body at rest at O.
  const Kinematics kin = rig.dyn->kinematics({u});
  const Configuration config(rig.c.insect, kin, rig.dyn->configuration().reference_point());
  const auto want = ns::InsectMotion(config, BodyMotion{}).parts(phase / (f0 + u));
  const auto got = fl->simulation().part_states();
  ASSERT_EQ(want.size(), got.size());
  double pose = 0, vel = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    pose = std::max({pose, double((got[i].pose.rotation - want[i].pose.rotation).norm()),
                     double((got[i].pose.translation - want[i].pose.translation).norm()) / rig.c.insect.wing.length});
    vel = std::max(vel, (got[i].velocity.omega - want[i].velocity.omega).norm());
  }
  std::printf("  parts against the commanded kinematics at the integrated phase: pose %.2e, angular velocity %.2e "
              "rad/s\n", pose, vel);
  EXPECT_LT(pose, 1e-10);
  EXPECT_LT(vel, 1e-8);
}

// A flight with the frequency as an actuator continues bit for bit from a checkpoint that keeps the wings' phase.
TEST(CfdFlight, FrequencyControlRestartContinuesBitForBit) {
  const StrokePlaneRig rig("cfd_flight_restart_freq.toml", false, "frequency_hz");
  const ControllerSpec ctrl = StrokePlaneRig::controller({{"theta", "frequency_hz", 200, 2.5 * rig.dt, 0}});
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(7) = 2.0;
  const auto ap = rig.flight(ctrl, no_deviation), bp = rig.flight(ctrl, no_deviation), rp = rig.flight(ctrl, no_deviation);
  CfdFlight &a = *ap, &b = *bp, &r = *rp;
  StrokePlaneRig::fly_split(a, b, r, x0);
  std::printf("  frequency-control restart: phase %.17g straight, %.17g continued (flow time x f %.17g)\n",
              a.current().phase, r.current().phase, a.current().time * rig.c.kinematics.frequency_hz);
  EXPECT_GT(std::abs(a.current().phase - a.current().time * rig.c.kinematics.frequency_hz), 1e-6);  // it acted
  EXPECT_EQ(a.current().phase, r.current().phase);
  for (int i = 0; i < 12; ++i) EXPECT_EQ(a.current().x(i), r.current().x(i)) << i;
  EXPECT_EQ(a.current().aero.force.z(), r.current().aero.force.z());
}

// The control authority of the stroke-plane tilt on the CFD model against the quasi-steady one: the shipped
// coupled-flight example (data/examples/fly_hawkmoth_cfd.toml, 8 cells per chord) at its quasi-steady trim, the
// cycle-mean wrench about the trimmed O with the stroke plane at +-3 deg (central difference, the moment carried to
// the trimmed O and the CoM shift's gravity moment left out: the aerodynamic part), each CFD run from the kept hover
// until its cycle mean converges. Recorded in docs/validation.md, not asserted. A long run (about 15 min on 2
// threads): FB_CACHE=DIR (default out/authority/cfd_cache) keeps the hover and the runs.
//   ./build/tests/test_flight --gtest_also_run_disabled_tests --gtest_filter='*StrokePlaneAuthority*'
TEST(CfdFlight, DISABLED_HawkmothStrokePlaneAuthority) {
  const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/examples/fly_hawkmoth_cfd.toml");
  Case qc = c;
  qc.aero.model = "quasi-steady";
  const auto qs = make_aero_model(qc);
  const TrimResult start = trim_hover(qc, *qs);
  ASSERT_TRUE(start.converged);
  const char* cache = std::getenv("FB_CACHE");
  ns::CfdModel cfd(c, &std::cout, cache ? cache : "out/authority/cfd_cache");
  cfd.plan_for(trim_extreme_kinematics(c, start));
  const Kinematics& kin = start.kinematics;
  const TrimParameterization par(kin, {unbounded_parameter("stroke_plane_deg")}, "");
  const Vec3 o = Configuration(c.insect, kin).reference_point();
  const double h = 3, W = c.insect.total_mass() * c.insect.gravity, Wc = W * c.insect.wing.mean_chord;
  auto mean_about_o = [&](const AeroModel& m, double delta) {
    const Kinematics k = par.apply({par.initial()[0] + delta});
    const Wrench w = m.run(c.insect, k, BodyMotion{}, AeroRunOptions{}).mean();
    const Vec3 d = Configuration(c.insect, k).reference_point() - o;
    return Wrench{w.force, w.moment + d.cross(w.force)};
  };
  const Wrench h0 = mean_about_o(cfd, 0), hp = mean_about_o(cfd, h), hm = mean_about_o(cfd, -h);
  const Wrench q0 = mean_about_o(*qs, 0), qp = mean_about_o(*qs, h), qm = mean_about_o(*qs, -h);
  auto row = [&](const char* name, const Wrench& z, const Wrench& p, const Wrench& m) {
    std::printf("  %s: hover Z %.4f W, M %+.4f W c; per deg of stroke plane: dX %+.5f W, dZ %+.5f W, dM %+.5f W c "
                "(+3: %+.5f, -3: %+.5f W c)\n",
                name, z.force.z() / W, z.moment.y() / Wc, (p.force.x() - m.force.x()) / (2 * h) / W,
                (p.force.z() - m.force.z()) / (2 * h) / W, (p.moment.y() - m.moment.y()) / (2 * h) / Wc,
                (p.moment.y() - z.moment.y()) / h / Wc, (z.moment.y() - m.moment.y()) / h / Wc);
  };
  row("quasi-steady", q0, qp, qm);
  row("CFD (8 cells per chord)", h0, hp, hm);
  std::printf("  CFD / quasi-steady dM per deg: %.3f; dX per deg: %.3f\n",
              (hp.moment.y() - hm.moment.y()) / (qp.moment.y() - qm.moment.y()),
              (hp.force.x() - hm.force.x()) / (qp.force.x() - qm.force.x()));
}

}  // namespace
