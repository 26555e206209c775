// Wall-bounded flows at low Reynolds number with exact solutions: Stokes' second problem and plane Poiseuille flow.
//
// Stokes' second problem (e.g. Schlichting & Gersten, Boundary-Layer Theory, ch. 5): a wall at y = 0 oscillates in its plane, u_wall = U0 cos(omega t), under
// fluid that starts at rest; the periodic state is u = U0 e^{-y/delta} cos(omega t - y/delta), delta = sqrt(2 nu/omega).
// U0 = 1, omega = 2 pi (period 1), delta = 0.1; domain x, z periodic (4 cells each), y in [0, 1] = 10 delta with a
// resting no-slip wall at y = 1 (e^{-10} = 5e-5 of U0 reaches it); y cells h = delta/10 up to 2 delta, stretched by
// <= 1.05 beyond. After 5 periods from rest the velocity profile is compared with the periodic state at 8 phases
// of the 6th period. Checks the moving-wall condition, a time-dependent boundary inside the RK stages, and
// diffusion on a stretched grid.
//
// Channel: uniform inflow U at x = 0, zero-gradient outflow (p = 0) at x = 3H, no-slip walls at y = 0 and H,
// Re = U H / nu = 10: downstream of the entrance length (~0.6 H at Re 10) the profile is Poiseuille's,
// u = 6 U (y/H)(1 - y/H), with the pressure gradient dp/dx = -12 nu U / H^2. 48 x 16 cells, t = 6 H/U.
#include <gtest/gtest.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include "cfd/navier_stokes/exact.hpp"
#include "cfd/navier_stokes/solver.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::pi;
using flapstab::Vec3;

constexpr double U0 = 1, omega = 2 * pi, delta = 0.1, nu = delta * delta * omega / 2;

struct StokesResult {
  double max_error;  // max over phases and y of |u - exact| / U0
  int ny, steps;
};

// h: spacing at the wall; periods: start-up periods before the measured one.
StokesResult run_stokes(double h, double ratio, int periods) {
  const Axis y = Axis::stretched(StretchedAxis{0, 1, 0, 2 * delta, h, ratio, 4}, false);
  const Grid g(Axis::uniform(0, 1, 4, true), y, Axis::uniform(0, 1, 4, true));
  Boundaries bc = Boundaries::all(BC::periodic);
  bc.face[face(1, 0)] = {BC::velocity, [](double t) { return Vec3(U0 * std::cos(omega * t), 0, 0); }, {}};
  bc.face[face(1, 1)] = {BC::velocity, {}, {}};
  SolverOptions opt;
  opt.nu = nu;
  // A whole number of steps per period, within the diffusion limit (which is what binds here).
  const double dt_limit = 0.5 / max_viscous_rate(g, nu);
  const int per_period = int(std::ceil(1.0 / dt_limit / 8)) * 8;
  opt.dt = 1.0 / per_period;
  Solver s(g, bc, opt);
  s.initialise([](double, double, double) { return Vec3::Zero(); });
  for (int n = 0; n < periods * per_period; ++n) s.step();
  StokesResult r{0, y.n, 0};
  for (int phase = 0; phase < 8; ++phase) {
    for (int n = 0; n < per_period / 8; ++n) s.step();
    for (int j = 1; j <= y.n; ++j)
      r.max_error = std::max(r.max_error, std::abs(s.velocity()[0](2, j, 2) - exact::stokes_second(y.xc[j], s.time(), U0, omega, nu)) / U0);
  }
  r.steps = (periods + 1) * per_period;
  return r;
}

// Tolerance 1e-2 U0 (CI grid, h = delta/10, 5 start-up periods; the start-up transient decays like t^-2 and the
// discretisation error like h^2). Second order: halving h (ratio -> sqrt) cuts the error by >= 3.
TEST(NavierStokesStokes, OscillatingWallProfile) {
  const StokesResult a = run_stokes(delta / 10, 1.05, 5);
  const StokesResult b = run_stokes(delta / 20, std::sqrt(1.05), 5);
  std::printf("  Stokes second problem: ny = %d: max |u - exact| = %.2e U0; ny = %d: %.2e U0\n", a.ny, a.max_error, b.ny,
              b.max_error);
  EXPECT_LT(a.max_error, 1e-2);
  EXPECT_GT(a.max_error / b.max_error, 3.0);
}

// Tolerances: 1e-2 U on the profile at x = 2H (measured 6e-3), 5 % on the pressure gradient between x = 1.5H and
// 2.5H, and the outflow carries the inflow (mass conservation) to 1e-10.
TEST(NavierStokesStokes, ChannelReachesPoiseuille) {
  const double H = 1, U = 1, nu = U * H / 10;
  const Grid g(Axis::uniform(0, 3 * H, 48, false), Axis::uniform(0, H, 16, false), Axis::uniform(0, H / 8, 1, true));
  Boundaries bc = Boundaries::all(BC::periodic);
  bc.face[face(0, 0)] = {BC::velocity, [U](double) { return Vec3(U, 0, 0); }, {}};
  bc.face[face(0, 1)] = {BC::outflow, {}, {}};
  bc.face[face(1, 0)] = {BC::velocity, {}, {}};
  bc.face[face(1, 1)] = {BC::velocity, {}, {}};
  SolverOptions opt;
  opt.nu = nu;
  opt.poisson.rtol = 1e-8;
  Solver s(g, bc, opt);
  s.initialise([U](double, double, double) { return Vec3(U, 0, 0); });
  while (s.time() < 6 * H / U) s.step();
  const Axis& y = g.axis[1];
  const int i2 = 33;  // face at x = 2H
  double err = 0, flux_in = 0, flux_out = 0;
  for (int j = 1; j <= y.n; ++j) {
    const double eta = y.xc[j] / H;
    err = std::max(err, std::abs(s.velocity()[0](i2, j, 1) - 6 * U * eta * (1 - eta)));
    flux_in += s.velocity()[0](1, j, 1) * y.dc[j];
    flux_out += s.velocity()[0](49, j, 1) * y.dc[j];
  }
  const int jm = y.n / 2;  // pressure gradient along the centre line between x = 1.5H and 2.5H
  const double dpdx = (s.pressure()(41, jm, 1) - s.pressure()(25, jm, 1)) / (g.axis[0].xc[41] - g.axis[0].xc[25]);
  std::printf("  channel Re 10: max |u - Poiseuille| = %.2e U at x = 2H, dp/dx = %.4f (exact %.4f), outflow/inflow - 1 = %.1e\n",
              err, dpdx, -12 * nu * U / (H * H), flux_out / flux_in - 1);
  EXPECT_LT(err, 1e-2 * U);
  EXPECT_NEAR(dpdx / (-12 * nu * U / (H * H)), 1.0, 0.05);
  EXPECT_NEAR(flux_out / flux_in, 1.0, 1e-10);
}

// Converged versions (docs/validation.md): run with
//   ./build/tests/test_cfd --gtest_also_run_disabled_tests --gtest_filter='NavierStokesConverged*'
TEST(NavierStokesConverged, DISABLED_StokesSecondProblem) {
  double ratio = 1.05, previous = 0;
  for (int level = 0; level < 3; ++level, ratio = std::sqrt(ratio)) {
    const auto t0 = std::chrono::steady_clock::now();
    const StokesResult r = run_stokes(delta / (10 << level), ratio, 8);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("  Stokes second problem h = delta/%d (ny = %d, %d steps, %.1f s): max |u - exact| = %.2e U0%s\n",
                10 << level, r.ny, r.steps, seconds, r.max_error,
                previous > 0 ? (", ratio " + std::to_string(previous / r.max_error)).c_str() : "");
    if (previous > 0) {
      EXPECT_GT(previous / r.max_error, 3.0);
    }
    previous = r.max_error;
  }
  EXPECT_LT(previous, 2e-4);
}

}  // namespace
