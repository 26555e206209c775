// Flapping Robofly wing (Dickinson, Lehmann & Sane 1999, Science 284:1954): docs/validation.md, "Flapping
// wing (Robofly, Dickinson et al. 1999)".
//
// Case. One membrane wing with the digitised Robofly planform (tests/common/robofly.hpp: FLUSI's
// 'robofly_dickinson' outline, pivot = hinge at the origin, tip at R = 1, root at 0.247 R) flaps in a
// horizontal stroke plane with the kinematics of the paper's Fig. 3 as fitted by the FLUSI authors (stroke
// phi(tau), feathering psi(tau) from the vertical, plateau 50 deg = 40 deg mid-stroke incidence; advanced
// rotation t_adv = +0.08 cycle), fluid at rest in a walled box [-3, 3] x [-2.5, 3.5] x [-2.5, 2.5] R, uniform
// fine box over the swept region, geometric stretching outside.
//
// Definitions (ours, chosen to match the revolving-wing case and Sun's group's convention; the paper's own
// reference speed was not found): U = mean speed at the radius of gyration, U = 2 Phi n r2 (Phi the stroke
// amplitude peak to peak, n the frequency); C = F / (1/2 rho U^2 S); Re = U c_bar / nu = 136 with c_bar = S / R
// (R hinge to tip). Lift = vertical force (normal to the stroke plane, up); drag = horizontal force opposing
// the wing's motion (minus the component along sign(phidot) times the stroke tangent of the span line).
//
// Reference. The measured force histories and mean coefficients of Dickinson et al. 1999 (Fig. 3) were NOT
// found in the searchable sources (docs/validation.md lists what was searched); there is therefore no
// comparison with measurements here. What is asserted is a MODEL CROSS-CHECK, not validation: flapstab's
// quasi-steady model (cfd/quasi_steady: Robofly translational fits + rotational circulation + added mass) on
// the same planform and kinematics. Tolerances were stated before the first run: mean C_L and mean C_D within
// 25 % of the model (the CFD lift of the revolving wing is 10-13 % below the same translational fits,
// docs/validation.md; the rotational and added-mass terms are models too), and a lift-history correlation
// above 0.8 over the last cycle.
#include <gtest/gtest.h>
#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <vector>
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/quasi_steady/quasi_steady.hpp"
#include "common/robofly.hpp"
#include "core/configuration.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::Mat3;
using flapstab::pi;
using flapstab::Vec3;
namespace rf = flapstab::robofly;

struct History {
  std::vector<double> cl, cd;  // on a uniform phase grid tau_k = k / N over one cycle
  double mean_cl = 0, mean_cd = 0;
};

struct FlappingResult {
  History cfd, qs, qs_translational;
  double corr_l = 0, corr_d = 0, rms_l = 0, rms_d = 0;  // CFD against the model
  double r2 = 0, area = 0, amplitude_deg = 0, period = 0;
  int nx = 0, ny = 0, nz = 0, steps = 0;
  double seconds = 0;
};

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s / double(v.size());
}
double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const double ma = mean(a), mb = mean(b);
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t k = 0; k < a.size(); ++k)
    sab += (a[k] - ma) * (b[k] - mb), saa += (a[k] - ma) * (a[k] - ma), sbb += (b[k] - mb) * (b[k] - mb);
  return sab / std::sqrt(saa * sbb);
}
double rms_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (std::size_t k = 0; k < a.size(); ++k) s += (a[k] - b[k]) * (a[k] - b[k]);
  return std::sqrt(s / double(a.size()));
}

// The quasi-steady model on the same wing and kinematics, one wing, rho = 1, same coefficient definitions.
History quasi_steady(double t_adv, double period, double U, int n, bool unsteady_terms = true) {
  using namespace flapstab;
  Insect in;
  in.name = "robofly";
  in.body.mass = 1;
  in.body.length = in.body.width = in.body.height = 0.1;
  in.body.inertia = in.body.ellipsoid_inertia();
  in.wing = rf::dickinson_wing();
  in.wing.mass = 1e-3;
  Mat3 ih;
  in.wing.plate_mass_properties(in.wing.mass_centre, ih);
  const Vec3& m = in.wing.mass_centre;
  in.wing.inertia_cg = ih - in.wing.mass * (m.squaredNorm() * Mat3::Identity() - m * m.transpose());
  Kinematics kin;
  kin.frequency_hz = 1 / period;
  kin.stroke_plane = 0;
  kin.body_angle = 0;
  // flapstab's pitch alpha is measured from the stroke plane with the leading edge forward; our feathering
  // psi > 0 has the leading edge leading while phi decreases (alpha > 90 deg there): alpha = 90 deg + psi.
  WingAngles w;
  w.stroke = rf::dickinson_stroke();
  FourierSeries p = rf::dickinson_feathering(t_adv);
  p.mean = pi / 2;
  w.pitch = p;
  kin.right = kin.left = w;
  const Configuration config(in, kin);
  QuasiSteadyOptions o;
  o.rho = 1;
  o.blade_elements = 200;
  o.rotational = o.added_mass = unsteady_terms;
  const QuasiSteadyModel model(o);
  const double q = 0.5 * U * U * in.wing.area();
  History h;
  for (int k = 0; k < n; ++k) {
    const double t = period * k / n;
    const WrenchSample s = model.instantaneous(in, kin, t, BodyMotion{});
    const WingPose pose = config.wing_pose(Side::right, t);
    const Vec3 v = pose.omega.cross(pose.axes.col(1));  // velocity of the span line's unit point
    const Vec3 F = s.right.force;
    h.cl.push_back(-F.z() / q);  // stability axes: z down
    h.cd.push_back(v.norm() > 1e-12 ? -F.dot(v.normalized()) / q : 0.0);
  }
  h.mean_cl = mean(h.cl), h.mean_cd = mean(h.cd);
  return h;
}

// t_adv: rotation timing (cycles); h = c_bar / cells_per_chord in the fine box; cycles run (last reported).
FlappingResult run_flapping(double t_adv, double cells_per_chord, double ratio, int cycles, double re = 136,
                            const char* csv = nullptr) {
  const auto t0 = std::chrono::steady_clock::now();
  const TriangleMesh mesh = rf::dickinson_wing_mesh(40, 10);
  const double S = mesh.area(), cbar = S / 1.0, r2 = rf::second_moment_radius(mesh);
  const flapstab::FourierSeries stroke = rf::dickinson_stroke(), feather = rf::dickinson_feathering(t_adv);
  double sum_a = 0;
  for (double a : stroke.a) sum_a += a;
  const double Phi = 2 * sum_a;  // odd cosine harmonics: phi(0) = -phi(1/2) = sum of the coefficients
  const double U = 1, T = 2 * Phi * r2 / U, nu = U * cbar / re;
  // Smooth start: the phase rate ramps from 0 to 1/T over a quarter cycle ((1 - cos) profile).
  const double t_ramp = 0.25 * T;
  auto tau_of = [=](double t) {
    return t < t_ramp ? (t / 2 - t_ramp / (2 * pi) * std::sin(pi * t / t_ramp)) / T : (t - t_ramp / 2) / T;
  };
  auto taudot_of = [=](double t) { return t < t_ramp ? 0.5 * (1 - std::cos(pi * t / t_ramp)) / T : 1 / T; };
  // Pose: R_z(phi) B(psi), B: wing x (to the leading edge) = (sin psi, 0, cos psi), wing y = span = +y,
  // wing z = x cross y. psi > 0 puts the leading edge towards +x, the direction of travel while phi decreases.
  PartMotion motion = [=](double t) {
    const double tau = tau_of(t), td = taudot_of(t);
    const auto ph = stroke.eval(tau), ps = feather.eval(tau);
    Mat3 B;
    B.col(0) = Vec3(std::sin(ps.f), 0, std::cos(ps.f));
    B.col(1) = Vec3(0, 1, 0);
    B.col(2) = B.col(0).cross(B.col(1));
    const Mat3 Rz = Eigen::AngleAxisd(ph.f, Vec3::UnitZ()).toRotationMatrix();
    const Vec3 omega = ph.df * td * Vec3::UnitZ() + ps.df * td * (Rz * Vec3::UnitY());
    return PartState{RigidTransform{Rz * B, Vec3::Zero()}, RigidVelocity{Vec3::Zero(), Vec3::Zero(), omega}};
  };

  const double h = cbar / cells_per_chord;
  double xmax = 0;
  for (const Vec3& v : mesh.vertices) xmax = std::max(xmax, std::abs(v.x()));
  const double zh = 1.05 * xmax + 2 * h;
  const Grid g(Axis::stretched(StretchedAxis{-3, 3, -1.05, 1.05, h, ratio, 8}, false),
               Axis::stretched(StretchedAxis{-2.5, 3.5, -0.3, 1.05, h, ratio, 8}, false),
               Axis::stretched(StretchedAxis{-2.5, 2.5, -zh, zh, h, ratio, 8}, false));
  rf::SingleWingFlow flow(g, nu, mesh, motion);
  Solver& s = flow.solver;
  ImmersedBoundary& ib = flow.ib;

  FlappingResult r;
  const Shape sh = g.shape();
  r.nx = sh.nx, r.ny = sh.ny, r.nz = sh.nz, r.r2 = r2, r.area = S, r.amplitude_deg = Phi / rf::deg, r.period = T;
  const double q = 0.5 * U * U * S;  // rho = 1
  std::vector<double> tau_s, cl_s, cd_s;
  double sl = 0, sd = 0, wsum = 0;
  while (tau_of(s.time()) < cycles) {
    const double dt = s.step();
    ++r.steps;
    const double t = s.time(), tau = tau_of(t);
    const auto ph = stroke.eval(tau);
    const double sgn = ph.df > 0 ? 1.0 : (ph.df < 0 ? -1.0 : 0.0);
    const Vec3 travel = sgn * Vec3(-std::cos(ph.f), -std::sin(ph.f), 0);  // d/dphi of the span direction
    const PartLoads L = ib.exchange_loads(s, Vec3::Zero())[0];
    const double cl = L.force().z() / q, cd = -L.force().dot(travel) / q;
    if (tau >= cycles - 1 - 0.02) tau_s.push_back(tau), cl_s.push_back(cl), cd_s.push_back(cd);
    if (tau >= cycles - 1) sl += cl * dt, sd += cd * dt, wsum += dt;
  }
  r.cfd.mean_cl = sl / wsum, r.cfd.mean_cd = sd / wsum;
  // Resample the last cycle on the uniform phase grid (linear interpolation).
  const int n = 100;
  std::size_t j = 0;
  for (int k = 0; k < n; ++k) {
    const double tau = cycles - 1 + double(k) / n;
    while (j + 2 < tau_s.size() && tau_s[j + 1] < tau) ++j;
    const double w = std::clamp((tau - tau_s[j]) / (tau_s[j + 1] - tau_s[j]), 0.0, 1.0);
    r.cfd.cl.push_back((1 - w) * cl_s[j] + w * cl_s[j + 1]);
    r.cfd.cd.push_back((1 - w) * cd_s[j] + w * cd_s[j + 1]);
  }
  r.qs = quasi_steady(t_adv, T, U, n);
  r.qs_translational = quasi_steady(t_adv, T, U, n, false);
  r.corr_l = correlation(r.cfd.cl, r.qs.cl), r.corr_d = correlation(r.cfd.cd, r.qs.cd);
  r.rms_l = rms_difference(r.cfd.cl, r.qs.cl), r.rms_d = rms_difference(r.cfd.cd, r.qs.cd);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (csv) {
    std::ofstream f(csv);
    f << "# flapping Robofly wing, last cycle; tau in cycles from the dorsal reversal (phi max); C = F / (rho U^2 S / 2), "
         "U = 2 Phi n r2\ntau,cl_cfd,cd_cfd,cl_quasi_steady,cd_quasi_steady\n";
    for (int k = 0; k < n; ++k)
      f << double(k) / n << ',' << r.cfd.cl[std::size_t(k)] << ',' << r.cfd.cd[std::size_t(k)] << ','
        << r.qs.cl[std::size_t(k)] << ',' << r.qs.cd[std::size_t(k)] << '\n';
  }
  return r;
}

void print(const char* label, const FlappingResult& r) {
  std::printf("  flapping Robofly wing, %s rotation, Re 136, S/R^2 %.4f, r2/R %.3f, stroke %.1f deg, T %.3f R/U "
              "(%d x %d x %d, %d steps, %.1f s), last cycle:\n"
              "    CFD (exchange) mean C_L %.3f, C_D %.3f; quasi-steady model mean C_L %.3f (%+.1f %%), C_D %.3f "
              "(%+.1f %%); history correlation lift %.3f, drag %.3f; RMS difference lift %.3f, drag %.3f\n",
              label, r.area, r.r2, r.amplitude_deg, r.period, r.nx, r.ny, r.nz, r.steps, r.seconds, r.cfd.mean_cl,
              r.cfd.mean_cd, r.qs.mean_cl, 100 * (r.cfd.mean_cl / r.qs.mean_cl - 1), r.qs.mean_cd,
              100 * (r.cfd.mean_cd / r.qs.mean_cd - 1), r.corr_l, r.corr_d, r.rms_l, r.rms_d);
  std::printf("    quasi-steady translational part only: mean C_L %.3f, C_D %.3f\n", r.qs_translational.mean_cl,
              r.qs_translational.mean_cd);
  std::printf("    tau   C_L cfd  C_L qs (transl.)   C_D cfd  C_D qs (transl.)\n");
  for (std::size_t k = 0; k < r.cfd.cl.size(); k += 5)
    std::printf("    %.2f  %7.3f  %7.3f (%6.3f)  %7.3f  %7.3f (%6.3f)\n", double(k) / double(r.cfd.cl.size()), r.cfd.cl[k],
                r.qs.cl[k], r.qs_translational.cl[k], r.cfd.cd[k], r.qs.cd[k], r.qs_translational.cd[k]);
}

// The a-priori tolerances: drag (mean within 25 %, history correlation > 0.8) and lift (mean within 25 %,
// correlation > 0.8).
void check_drag_against_model(const FlappingResult& r) {
  EXPECT_NEAR(r.cfd.mean_cd / r.qs.mean_cd, 1.0, 0.25);
  EXPECT_GT(r.corr_d, 0.8);
}
void check_lift_against_model(const FlappingResult& r) {
  EXPECT_NEAR(r.cfd.mean_cl / r.qs.mean_cl, 1.0, 0.25);
  EXPECT_GT(r.corr_l, 0.8);
}

// The kinematics and planform evaluate as documented: stroke amplitude, mid-stroke incidence, rotation timing.
TEST(FlappingRoboflyKinematics, FourierFitsGiveTheDocumentedMotion) {
  const auto stroke = rf::dickinson_stroke();
  const auto adv = rf::dickinson_feathering(0.08), sym = rf::dickinson_feathering(0);
  EXPECT_NEAR(stroke.eval(0).f / rf::deg, 70.9, 0.1);       // dorsal reversal, phi max
  EXPECT_NEAR(stroke.eval(0.5).f / rf::deg, -70.9, 0.1);
  EXPECT_NEAR(sym.eval(0.25).f / rf::deg, 50.0, 0.2);       // mid-stroke: 90 - 50 = 40 deg incidence
  EXPECT_NEAR(sym.eval(0).f, 0.0, 1e-12);                   // symmetrical: vertical at the reversal
  EXPECT_NEAR(adv.eval(0.92).f, 0.0, 1e-12);                // advanced: vertical 0.08 cycle before it
  const TriangleMesh m = rf::dickinson_wing_mesh(40, 10);
  EXPECT_NEAR(m.area(), 0.2522 / (0.99816 * 0.99816), 0.003);  // outline area 0.2522 in FLUSI units
  const flapstab::Wing w = rf::dickinson_wing();
  EXPECT_NEAR(w.area(), m.area(), 1e-12);
}

// The model cross-check alone (no CFD): prints the quasi-steady histories of the three rotation timings.
TEST(FlappingRoboflyKinematics, QuasiSteadyHistoriesOfFig3Timings) {
  const TriangleMesh mesh = rf::dickinson_wing_mesh(40, 10);
  double sum_a = 0;
  for (double a : rf::dickinson_stroke().a) sum_a += a;
  const double T = 2 * 2 * sum_a * rf::second_moment_radius(mesh);
  for (double t_adv : {0.08, 0.0, -0.08}) {
    const History full = quasi_steady(t_adv, T, 1, 20), tr = quasi_steady(t_adv, T, 1, 20, false);
    std::printf("  t_adv %+.2f: quasi-steady mean C_L %.3f (translational %.3f), C_D %.3f (translational %.3f)\n", t_adv,
                full.mean_cl, tr.mean_cl, full.mean_cd, tr.mean_cd);
    for (std::size_t k = 0; k < 20; ++k)
      std::printf("    %.2f  C_L %7.3f (%6.3f)  C_D %7.3f (%6.3f)\n", k / 20.0, full.cl[k], tr.cl[k], full.cd[k], tr.cd[k]);
    EXPECT_GT(full.mean_cl, 0);
  }
}

// Coarse (c_bar / 8 in the fine box, two wingbeats each, the second reported): the three rotation timings of Fig. 3
// (advanced t_adv = +0.08, FLUSI's default; symmetrical; delayed -0.08). Out of the CI suite since 2026-12-08 (about
// 4 min on one thread, the suite's longest test; the CI has a 30-minute budget on 2 cores); run it by name:
//   ./build/tests/test_cfd --gtest_also_run_disabled_tests --gtest_filter='*RoboflyRotationTimingOrdersTheLift'
// The same ordering is printed on c_bar / 12 and c_bar / 16 by
// ImmersedStudy.DISABLED_FlappingRoboflyTimingRatiosMedium.
// Asserted: (1) the published ordering of the mean lift with the rotation timing, the one statement about these
// kinematics the searchable sources confirm (Sun & Tang 2002, J Exp Biol 205:2413, abstract, from their CFD of
// the same three timings; Dickinson et al. 1999 report the same in kind): advanced rotation gives more lift
// than symmetrical, delayed rotation "much less" (read here as at least 25 % less); (2) the drag cross-check
// against the quasi-steady model for advanced rotation (guards the flapping machinery: kinematics, rotation
// sense, loads). NOT asserted here: the lift cross-check against the model, which FAILS its a-priori
// tolerances (advanced: mean C_L 55 % below the model, correlation 0.30; docs/validation.md, "Flapping wing",
// Findings) — an open disagreement between the CFD and the model that no measurement available here can
// settle. The lift checks stay in the converged test (ImmersedConverged.DISABLED_FlappingRoboflyAdvanced),
// where they fail until it is resolved.
TEST(ImmersedFlappingWing, DISABLED_RoboflyRotationTimingOrdersTheLift) {
  const FlappingResult adv = run_flapping(0.08, 8, 1.1, 2), sym = run_flapping(0.0, 8, 1.1, 2),
                       del = run_flapping(-0.08, 8, 1.1, 2);
  print("advanced", adv);
  print("symmetrical", sym);
  print("delayed", del);
  EXPECT_GT(adv.cfd.mean_cl, sym.cfd.mean_cl);
  EXPECT_LT(del.cfd.mean_cl, 0.75 * sym.cfd.mean_cl);
  check_drag_against_model(adv);
}

TEST(ImmersedStudy, DISABLED_FlappingRoboflyAdvancedMedium) { print("advanced", run_flapping(0.08, 12, 1.1, 3)); }

// The rotation timings against the measured ratios of the cycle-mean lift of Dickinson, Lehmann & Sane 1999
// (Science 284:1954, Fig. 3; third-party digitisation): advanced : symmetrical : delayed = 1.04 : 1 : 0.50
// (ratios do not depend on the normalisation). Intermediate grid (c_bar / 12, three wingbeats, the last
// reported); recorded in docs/validation.md, not asserted (the grid trend of finding 8 is not converged here).
TEST(ImmersedStudy, DISABLED_FlappingRoboflyTimingRatiosMedium) {
  const double cpc = std::getenv("ROBOFLY_CPC") ? std::atof(std::getenv("ROBOFLY_CPC")) : 12;
  const FlappingResult adv = run_flapping(0.08, cpc, 1.1, 3), sym = run_flapping(0.0, cpc, 1.1, 3),
                       del = run_flapping(-0.08, cpc, 1.1, 3);
  print("advanced", adv);
  print("symmetrical", sym);
  print("delayed", del);
  std::printf("  c/%.0f mean-lift ratios advanced : symmetrical : delayed = %.3f : 1 : %.3f (measured 1.04 : 1 : 0.50)\n",
              cpc, adv.cfd.mean_cl / sym.cfd.mean_cl, del.cfd.mean_cl / sym.cfd.mean_cl);
}

// Converged grid (c_bar / 16, ratio 1.1), three wingbeats, the last reported and written to
// docs/figures/robofly_flapping_forces.csv; run with
//   ./build/tests/test_cfd --gtest_also_run_disabled_tests --gtest_filter='ImmersedConverged.DISABLED_FlappingRobofly*'
TEST(ImmersedConverged, DISABLED_FlappingRoboflyAdvanced) {
  const FlappingResult r =
      run_flapping(0.08, 16, 1.1, 3, 136, FLAPSTAB_SOURCE_DIR "/docs/figures/robofly_flapping_forces.csv");
  print("advanced", r);
  check_drag_against_model(r);
  check_lift_against_model(r);
}

}  // namespace
