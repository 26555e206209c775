// Revolving wing at constant angle of attack (Robofly translational coefficients): docs/validation.md,
// "Revolving wing (Robofly)"; spec docs: CFD.md, Validation, "Flapping wing".
//
// Reference (REFERENCE.md, "Quasi-steady coefficients"): Dickinson, Lehmann & Sane 1999 (Science 284:1954),
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
// gives r2/R = 0.56 close to the fly's 0.55-0.58), the aspect ratio R / c_bar = 3.74 (wing area about
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
#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>
#include "cfd/navier_stokes/immersed.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::Mat3;
using flapstab::pi;
using flapstab::Planform;
using flapstab::Vec3;
using flapstab::Wing;

constexpr double deg = pi / 180;

double robofly_cl(double alpha_deg) { return 0.225 + 1.58 * std::sin((2.13 * alpha_deg - 7.20) * deg); }
double robofly_cd(double alpha_deg) { return 1.92 - 1.55 * std::cos((2.04 * alpha_deg - 9.82) * deg); }

// Drosophila-like planform: a full ellipse over 0 <= r <= R (chord zero at root and tip), mean chord R / AR,
// tabulated with stations clustered at both ends.
Wing robofly_wing(double aspect_ratio) {
  Wing w;
  w.length = 1;
  w.mean_chord = 1 / aspect_ratio;
  w.planform = Planform::tabulated;
  w.pitch_axis = 0.25;
  const int n = 40;
  for (int j = 0; j <= n; ++j) {
    const double r = 0.5 * (1 - std::cos(pi * j / n));  // clustered at root and tip
    w.table_r.push_back(r);
    w.table_c.push_back(4 / pi * std::sqrt(std::max(0.0, 1 - (2 * r - 1) * (2 * r - 1))));
  }
  return w;
}

struct RevolvingResult {
  double cl, cd, cd_torque;   // momentum exchange, window mean
  double cl_surface, cd_surface;
  double r2, area;
  int nx, ny, nz, steps;
  double seconds;
};

// alpha (degrees), h = c_bar / cells_per_chord in the fine box, stretching ratio.
RevolvingResult run_revolving(double alpha_deg, double cells_per_chord, double ratio, double re = 136,
                              double aspect_ratio = 3.74) {
  const auto t0 = std::chrono::steady_clock::now();
  const Wing wing = robofly_wing(aspect_ratio);
  const TriangleMesh mesh = wing_mesh(wing, 40, 10);
  const double S = mesh.area(), cbar = S / wing.length;
  // r2 of the meshed planform: (int r^2 dA / S)^(1/2), triangle-wise (centroid plus second moment).
  double I2 = 0;
  for (std::size_t k = 0; k < mesh.size(); ++k) {
    const double a = mesh.area_vector(k).norm();
    const double y0 = mesh.vertex(k, 0).y(), y1 = mesh.vertex(k, 1).y(), y2 = mesh.vertex(k, 2).y();
    I2 += a / 6 * (y0 * y0 + y1 * y1 + y2 * y2 + y0 * y1 + y1 * y2 + y2 * y0);
  }
  const double r2 = std::sqrt(I2 / S);
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
  const double cmax = 4 / pi * cbar;
  const Grid g(Axis::stretched(StretchedAxis{-3, 3, -1.05, 1.05, h, ratio, 8}, false),
               Axis::stretched(StretchedAxis{-3, 3, -1.05, 1.05, h, ratio, 8}, false),
               Axis::stretched(StretchedAxis{-2.5, 2.5, -0.8 * cmax - 2 * h, 0.8 * cmax + 2 * h, h, ratio, 8}, false));
  SolverOptions opt;
  opt.nu = nu;
  opt.cfl = 1.2;
  Solver s(g, Boundaries::all(BC::velocity), opt);
  s.initialise([](double, double, double) { return Vec3::Zero(); });
  ImmersedBoundary ib(g);
  ib.add_part(mesh, motion);
  ib.attach(s);

  RevolvingResult r{};
  const Shape sh = g.shape();
  r.nx = sh.nx, r.ny = sh.ny, r.nz = sh.nz, r.r2 = r2, r.area = S;
  const double q = 0.5 * U * U * S;  // rho = 1
  const double phi_lo = 60 * deg, phi_hi = 120 * deg;
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
  std::printf("  revolving wing alpha %.0f deg, Re 136, AR 3.74, r2/R %.3f (%d x %d x %d, %d steps, %.1f s), window 60-120 deg:\n"
              "    exchange C_L %.3f (Robofly %.3f, %+.1f %%), C_D %.3f (Robofly %.3f, %+.1f %%), torque/r2 C_D %.3f; "
              "surface integral C_L %.3f, C_D %.3f\n",
              alpha, r.r2, r.nx, r.ny, r.nz, r.steps, r.seconds, r.cl, rl, 100 * (r.cl / rl - 1), r.cd, rd,
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

}  // namespace
