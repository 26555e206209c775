// Revolving wing at constant angle of attack (Robofly translational coefficients): docs/validation.md,
// "Revolving wing (Robofly)".
//
// Reference: Dickinson, Lehmann & Sane 1999 (Science 284:1954),
// the dynamically scaled fruit-fly wing ("Robofly": a 0.25 m Plexiglas wing in mineral oil, density 880 kg/m^3;
// the oil's viscosity, about 115 cSt, and a 180 degree constant-speed sweep are recalled, NOT confirmed in the
// searchable sources) revolved at constant angular velocity and constant angle of attack; the translational lift
// and drag coefficients of the steady middle part of the sweep were fitted as (alpha in degrees)
//     C_L = 0.225 + 1.58 sin(2.13 alpha - 7.20),   C_D = 1.92 - 1.55 cos(2.04 alpha - 9.82).
// The quasi-steady model these fits feed (Dickinson et al. 1999; Sane & Dickinson 2001, J Exp Biol 204:2607) is
// F = 1/2 rho C U_tip^2 S r2^2 with r2 the non-dimensional radius of the second moment of area, i.e.
// F = 1/2 rho C S U(r2)^2 with U(r2) = Omega r2 R the speed at the radius of gyration: that is the definition
// used here. Lift is the vertical force (normal to the stroke plane), drag the horizontal force opposing the
// wing's motion (perpendicular to the span). What the search tool confirmed: the fits themselves (several
// public quasi-steady codes carry the same constants, and use them with U at r2 or U_tip^2 r2^2 S); the Robofly
// wing length 0.25 m and oil density 880 kg/m^3 (a Robofly analysis code). What is ASSUMED (not found in the
// searchable corpora): the planform (Drosophila-like; modelled here as a full ellipse over 0 <= r <= R, which
// gives r2/R = 0.56 close to the fly's 0.55-0.58; the converged 45-degree case is also run on the digitised
// Robofly outline published with FLUSI, tests/common/robofly.hpp), the aspect ratio R / c_bar = 3.74 (wing area about
// 0.0167 m^2 for R = 0.25 m, as recalled from Sane & Dickinson 2001), no root offset, and the Reynolds number:
// the Robofly range is Re = 100-200; we use Re = U(r2) c_bar / nu = 136 (the value quoted for Dickinson et
// al.'s hovering kinematics; for a revolving wing the coefficients depend weakly on Re in this range).
//
// Set-up (R = 1, rho = 1, U(r2) = 1): the wing's hinge at the origin, span horizontal, revolving about the
// vertical z axis. Its angular velocity ramps smoothly from 0 to Omega = U / r2 over the first 10 degrees of
// revolution ((1 - cos) profile), then stays constant; the geometric angle of attack alpha (pitch about the
// spanwise axis through the quarter chord, leading edge up) is fixed. Fluid at rest in a walled box
// [-3, 3]^2 x [-2.5, 2.5] R, uniform fine box over the swept disc, geometric stretching outside. Loads from the
// momentum exchange of the forcing (exchange_loads: the accurate estimate on coarse grids, docs/validation.md,
// "Immersed boundary"); the surface integral is printed, not asserted. Coefficients are averaged over the
// window 60-120 degrees of revolution (about 2-4 mean chords of travel at r2, after the start-up transient
// and while the leading-edge vortex stays attached; Dickinson's fits are from mid-stroke of a sweep of,
// as recalled and not confirmed, 180 degrees: 3-4 chords of travel at r2).
#include <gtest/gtest.h>
#include <cstdlib>
#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>
#include "cfd/navier_stokes/immersed.hpp"
#include "common/robofly.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::Mat3;
using flapstab::pi;
using flapstab::Vec3;

using flapstab::robofly::deg;
namespace rf = flapstab::robofly;
double robofly_cl(double alpha_deg) { return flapstab::robofly::translational_cl(alpha_deg); }
double robofly_cd(double alpha_deg) { return flapstab::robofly::translational_cd(alpha_deg); }

// Which planform: the full-ellipse stand-in (aspect ratio 3.74) or the digitised Robofly drawing
// (tests/common/robofly.hpp: FLUSI's 'robofly_dickinson', pivot at the hinge, root at 0.247 R).
enum class RoboflyPlanform { ellipse, dickinson };

struct RevolvingResult {
  double cl, cd, cd_torque;   // momentum exchange, window mean
  double cl_surface, cd_surface;
  double r2, area;
  const char* planform;
  int nx, ny, nz, steps;
  double seconds;
};

// The domain and the averaging window (the defaults are the recorded cases'): walls at +-box R across, +-0.833 box
// R vertically; the window's revolution angles in degrees.
struct RevolvingSetup {
  double box = 3, phi_lo = 60, phi_hi = 120;
  double aspect_ratio = 3.74;  // R / c_bar of the elliptic planform
};

// alpha (degrees), h = c_bar / cells_per_chord in the fine box, stretching ratio.
RevolvingResult run_revolving(double alpha_deg, double cells_per_chord, double ratio, double re = 136,
                              RoboflyPlanform planform = RoboflyPlanform::ellipse, RevolvingSetup setup = {}) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool ellipse = planform == RoboflyPlanform::ellipse;
  const TriangleMesh mesh = ellipse ? wing_mesh(flapstab::robofly::elliptic_wing(setup.aspect_ratio), 40, 10)
                                    : flapstab::robofly::dickinson_wing_mesh(40, 10);
  const double S = mesh.area(), cbar = S / 1.0;  // R = 1 (hinge to tip)
  // r2 of the meshed planform about the hinge: (int r^2 dA / S)^(1/2), triangle-wise.
  const double r2 = flapstab::robofly::second_moment_radius(mesh);
  // Half-height of the fine box: the chord's largest distance from the pitch axis (plus two cells below).
  double xmax = 0;
  for (const Vec3& v : mesh.vertices) xmax = std::max(xmax, std::abs(v.x()));
  const double zhalf = ellipse ? 0.8 * 4 / pi * cbar : 1.05 * xmax;
  const double U = 1, Omega = U / r2, nu = U * cbar / re;
  const double phi_ramp = 10 * deg, t_ramp = 2 * phi_ramp / Omega;  // (1 - cos) ramp: phi(t_ramp) = Omega t_ramp / 2
  auto phi_of = [=](double t) {
    return t < t_ramp ? Omega * (t / 2 - t_ramp / (2 * pi) * std::sin(pi * t / t_ramp)) : Omega * (t - t_ramp / 2);
  };
  auto rate_of = [=](double t) { return t < t_ramp ? Omega * 0.5 * (1 - std::cos(pi * t / t_ramp)) : Omega; };
  // Wing frame at phi = 0: span y along world +y, travel direction d = -x (omega = +z), chord (to the leading
  // edge) = cos(alpha) d + sin(alpha) z: leading edge up, lift +z.
  const double a = alpha_deg * deg;
  const Vec3 d(-1, 0, 0), up(0, 0, 1);
  Mat3 B;
  B.col(0) = std::cos(a) * d + std::sin(a) * up;
  B.col(1) = Vec3(0, 1, 0);
  B.col(2) = B.col(0).cross(B.col(1));
  PartMotion motion = [=](double t) {
    const Mat3 Rz = Eigen::AngleAxisd(phi_of(t), Vec3::UnitZ()).toRotationMatrix();
    return PartState{RigidTransform{Rz * B, Vec3::Zero()}, RigidVelocity{Vec3::Zero(), Vec3::Zero(), Vec3(0, 0, rate_of(t))}};
  };

  const double h = cbar / cells_per_chord;
  const double W = setup.box, Wz = 2.5 / 3 * setup.box;
  const Grid g(Axis::stretched(StretchedAxis{-W, W, -1.05, 1.05, h, ratio, 8}, false),
               Axis::stretched(StretchedAxis{-W, W, -1.05, 1.05, h, ratio, 8}, false),
               Axis::stretched(StretchedAxis{-Wz, Wz, -zhalf - 2 * h, zhalf + 2 * h, h, ratio, 8}, false));
  rf::SingleWingFlow flow(g, nu, mesh, motion);
  Solver& s = flow.solver;
  ImmersedBoundary& ib = flow.ib;

  RevolvingResult r{};
  const Shape sh = g.shape();
  r.nx = sh.nx, r.ny = sh.ny, r.nz = sh.nz, r.r2 = r2, r.area = S;
  r.planform = ellipse ? "ellipse AR 3.74" : "Dickinson drawing (FLUSI robofly_dickinson)";
  const double q = 0.5 * U * U * S;  // rho = 1
  const double phi_lo = setup.phi_lo * deg, phi_hi = setup.phi_hi * deg;
  double sl = 0, sd = 0, sq = 0, sls = 0, sds = 0, wsum = 0;
  double next_print = 15 * deg;
  std::vector<double> hist;
  while (phi_of(s.time()) < phi_hi) {
    const double dt = s.step();
    ++r.steps;
    const double t = s.time(), phi = phi_of(t);
    const Vec3 travel(-std::cos(phi), -std::sin(phi), 0);  // R_z(phi) d
    const PartLoads L = ib.exchange_loads(s, Vec3::Zero())[0];
    const double cl = L.force().z() / q, cd = -L.force().dot(travel) / q;
    if (phi >= next_print) {
      std::printf("    phi %5.1f deg (%.2f chords at r2): C_L %.3f, C_D %.3f\n", phi / deg, phi * r2 / cbar, cl, cd);
      next_print += 15 * deg;
    }
    if (phi >= phi_lo) {
      const PartLoads Ls = ib.loads(s, Vec3::Zero())[0];
      sl += cl * dt, sd += cd * dt;
      sq += -L.moment().z() / r2 / q * dt;  // aerodynamic torque about the axis / r2
      sls += Ls.force().z() / q * dt, sds += -Ls.force().dot(travel) / q * dt;
      wsum += dt;
    }
  }
  r.cl = sl / wsum, r.cd = sd / wsum, r.cd_torque = sq / wsum, r.cl_surface = sls / wsum, r.cd_surface = sds / wsum;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

void print(double alpha, const RevolvingResult& r) {
  const double rl = robofly_cl(alpha), rd = robofly_cd(alpha);
  std::printf("  revolving wing alpha %.0f deg, Re 136, %s, S/R^2 %.4f, r2/R %.3f (%d x %d x %d, %d steps, %.1f s), window 60-120 deg:\n"
              "    exchange C_L %.3f (Robofly %.3f, %+.1f %%), C_D %.3f (Robofly %.3f, %+.1f %%), torque/r2 C_D %.3f; "
              "surface integral C_L %.3f, C_D %.3f\n",
              alpha, r.planform, r.area, r.r2, r.nx, r.ny, r.nz, r.steps, r.seconds, r.cl, rl, 100 * (r.cl / rl - 1), r.cd, rd,
              100 * (r.cd / rd - 1), r.cd_torque, r.cl_surface, r.cd_surface);
}

// CI: alpha = 45 deg, 8 cells per mean chord in the fine box, ratio 1.1.
TEST(ImmersedStudy, DISABLED_RevolvingWingCoarseAlpha20) {
  const RevolvingResult r = run_revolving(20, 8, 1.1);
  print(20, r);
}

// Intermediate grid (12 cells per mean chord, ratio 1.1), recorded for the grid trend, not asserted.
TEST(ImmersedStudy, DISABLED_RevolvingWingMediumAlpha45) {
  const RevolvingResult r = run_revolving(45, 12, 1.1);
  print(45, r);
}

TEST(ImmersedRevolvingWing, RoboflyCoefficientsAt45Degrees) {
  const double alpha = 45;
  const RevolvingResult r = run_revolving(alpha, 8, 1.1);
  print(alpha, r);
  EXPECT_NEAR(r.cl / robofly_cl(alpha), 1.0, 0.20);
  EXPECT_NEAR(r.cd / robofly_cd(alpha), 1.0, 0.20);
}

// Converged versions (16 cells per mean chord, ratio 1.1; tolerance 10 %): run with
//   ./build/tests/test_cfd --gtest_also_run_disabled_tests --gtest_filter='ImmersedConverged.DISABLED_RevolvingWing*'
void converged(double alpha) {
  const RevolvingResult r = run_revolving(alpha, 16, 1.1);
  print(alpha, r);
  EXPECT_NEAR(r.cl / robofly_cl(alpha), 1.0, 0.10);
  EXPECT_NEAR(r.cd / robofly_cd(alpha), 1.0, 0.10);
}
TEST(ImmersedConverged, DISABLED_RevolvingWingRoboflyAlpha45) { converged(45); }
TEST(ImmersedConverged, DISABLED_RevolvingWingRoboflyAlpha20) { converged(20); }
TEST(ImmersedConverged, DISABLED_RevolvingWingRoboflyAlpha60) { converged(60); }

// The 45-degree converged case on the digitised Robofly planform (tests/common/robofly.hpp) instead of the
// ellipse: checks whether the assumed planform explains the lift gap (docs/validation.md). Same tolerance.
TEST(ImmersedConverged, DISABLED_RevolvingWingRoboflyDickinsonPlanformAlpha45) {
  const RevolvingResult r = run_revolving(45, 16, 1.1, 136, RoboflyPlanform::dickinson);
  print(45, r);
  EXPECT_NEAR(r.cl / robofly_cl(45), 1.0, 0.10);
  EXPECT_NEAR(r.cd / robofly_cd(45), 1.0, 0.10);
}

// Any case of the study, for the lift-gap candidates (docs/validation.md, "Revolving wing"): environment
// RW_ALPHA (deg, 45), RW_CPC (cells per mean chord, 12), RW_RE (136), RW_BOX (wall half-width in R, 3), RW_LO and
// RW_HI (the window, deg, 60 and 120), RW_AR (the ellipse's R / c_bar, 3.74).
double env_or(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v ? std::atof(v) : fallback;
}
TEST(ImmersedStudy, DISABLED_RevolvingWingProbe) {
  const double alpha = env_or("RW_ALPHA", 45);
  const RevolvingSetup setup{env_or("RW_BOX", 3), env_or("RW_LO", 60), env_or("RW_HI", 120), env_or("RW_AR", 3.74)};
  const RevolvingResult r = run_revolving(alpha, env_or("RW_CPC", 12), 1.1, env_or("RW_RE", 136),
                                          RoboflyPlanform::ellipse, setup);
  std::printf("  box +-%.1f R, window %.0f-%.0f deg, Re %.0f, aspect ratio %.2f:\n", setup.box, setup.phi_lo,
              setup.phi_hi, env_or("RW_RE", 136), setup.aspect_ratio);
  print(alpha, r);
}

}  // namespace
