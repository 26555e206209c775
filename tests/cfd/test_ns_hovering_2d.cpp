// The 2-D hovering wing of Wang, Birch & Dickinson 2004 (J Exp Biol 207:449-460) at Re = 75: docs/validation.md,
// "2-D hovering wing (Wang, Birch & Dickinson 2004)".
//
// References (data/reference/wbd2004-hovering-2d/, redistributed from barbagroup/petibm-examples, BSD-3): the
// robotic-wing measurement of Wang et al. 2004 and two CFD results, Eldredge 2007 (J Comput Phys 221:626,
// viscous vortex particles) and Li, Dong & Liu 2015 (J Fluids Struct 58:49, immersed boundary), as lift and drag
// histories normalised by the quasi-steady maxima. Their mean C_L over cycles 2-4: 0.487-0.501 (the two CFD
// codes), 0.447 (experiment). Targets of the issue on the converged grid: within 5 % of the CFD pair, within
// 15 % of the measurement.
#include <gtest/gtest.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include "cfd/navier_stokes/hovering_2d.hpp"
#include "core/errors.hpp"

namespace {

using namespace flapstab::ns;

std::string ref(const std::string& name) {
  return std::string(FLAPSTAB_SOURCE_DIR) + "/data/reference/wbd2004-hovering-2d/" + name;
}

// The normalisation of the published histories: the README of the reference data (and PetIBM's script of the
// case) give L_max ~ 3.02 and D_max ~ 3.74 per unit span for points along the chord. Analytic check of the
// fold: at mid-stroke of the first half (t = T/4) the chord angle is 3 pi/4, alpha_e = pi/4, C_L,qs = 1.2,
// the centre moves at U_max and the rotation rate is zero, so L(T/4) = 1/2 U_max^2 1.2 = 2.902.
TEST(Hovering2d, QuasiSteadyMaximaOfTheNormalisation) {
  const Hovering2dCase c;
  const QuasiSteadyMaxima m = hovering_2d_quasi_steady_maxima(c);
  std::printf("  quasi-steady maxima (101 chord points, 20000 samples per cycle): L_max %.4f, D_max %.4f\n", m.lift, m.drag);
  EXPECT_NEAR(m.lift, 3.02, 0.01);
  EXPECT_NEAR(m.drag, 3.74, 0.01);
  EXPECT_GT(m.lift, 0.5 * c.max_speed() * c.max_speed() * 1.2);
  // The other convention found with the same reference curves (barbagroup's cuIBM): 1/2 U_max^2 c x 1.2, x 1.4.
  EXPECT_NEAR(m.lift_translational, 2.9017, 1e-4);
  EXPECT_NEAR(m.drag_translational, 3.3853, 1e-4);
  const Hovering2dKinematics k = hovering_2d_kinematics(c, c.period() / 4);
  EXPECT_NEAR(k.u, -c.max_speed(), 1e-12);
  EXPECT_NEAR(k.alpha, 3 * flapstab::pi / 4, 1e-12);
  EXPECT_NEAR(k.omega, 0, 1e-12);
  EXPECT_EQ(k.direction, -1);
  EXPECT_EQ(hovering_2d_kinematics(c, 0.75 * c.period()).direction, 1);
}

// The shipped histories and the published cycle-mean rule reproduce the table of cycle means in the reference
// data's README (trapezoid rule over the points of each cycle) to its three digits.
TEST(Hovering2d, ReferenceCycleMeans) {
  struct Row { const char* file; double m[4]; };
  const Row rows[] = {{"CL_Wang2004_experiment.dat", {0.458, 0.449, 0.453, 0.440}},
                      {"CL_Eldredge2007.dat", {0.586, 0.501, 0.498, 0.490}},
                      {"CL_Li2015.dat", {0.566, 0.487, 0.493, 0.490}},
                      {"CD_Wang2004_experiment.dat", {0.653, 0.681, 0.688, 0.691}},
                      {"CD_Eldredge2007.dat", {0.797, 0.794, 0.765, 0.721}},
                      {"CD_Li2015.dat", {0.768, 0.772, 0.750, 0.736}}};
  for (const Row& r : rows) {
    const CoefficientHistory h = read_coefficient_history(ref(r.file), r.file);
    for (int k = 1; k <= 4; ++k) EXPECT_NEAR(published_mean(h, k - 1, k), r.m[k - 1], 0.0006) << r.file << " cycle " << k;
  }
}

TEST(Hovering2d, BadReferenceFileNamesFileAndLine) {
  const std::string path = ::testing::TempDir() + "/bad_history.dat";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("0.1 0.2\n0.2 x\n", f);
    std::fclose(f);
  }
  try {
    read_coefficient_history(path, "bad");
    FAIL() << "no error";
  } catch (const flapstab::InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  Hovering2dCase c;
  c.box_x = {-1, 1};  // narrower than the stroke
  EXPECT_THROW(c.check(), std::invalid_argument);
}

struct Comparison {
  double cl, cd, cl_surface;
  HistoryComparison l_exp, l_el, l_li, d_exp, d_el, d_li;
};

Comparison compare(const Hovering2dResult& r) {
  std::vector<double> tau{0.0}, cl{0.0}, cd{0.0};
  for (const auto& s : r.samples) tau.push_back(s.phase), cl.push_back(s.cl), cd.push_back(s.cd);
  Comparison c{};
  if (r.cycle_cl.size() < 4) {
    std::printf("  %zu cycles, spanwise deviation %.2e U_max, %ld steps, %.1f s\n", r.cycle_cl.size(), r.spanwise_deviation, r.steps, r.seconds);
    return c;
  }
  c.cl = (r.cycle_cl[1] + r.cycle_cl[2] + r.cycle_cl[3]) / 3;
  c.cd = (r.cycle_cd[1] + r.cycle_cd[2] + r.cycle_cd[3]) / 3;
  c.cl_surface = (r.cycle_cl_surface[1] + r.cycle_cl_surface[2] + r.cycle_cl_surface[3]) / 3;
  c.l_exp = compare_history(tau, cl, read_coefficient_history(ref("CL_Wang2004_experiment.dat"), "exp"), 1, 4);
  c.l_el = compare_history(tau, cl, read_coefficient_history(ref("CL_Eldredge2007.dat"), "Eldredge"), 1, 4);
  c.l_li = compare_history(tau, cl, read_coefficient_history(ref("CL_Li2015.dat"), "Li"), 1, 4);
  c.d_exp = compare_history(tau, cd, read_coefficient_history(ref("CD_Wang2004_experiment.dat"), "exp"), 1, 4, 0.02);
  c.d_el = compare_history(tau, cd, read_coefficient_history(ref("CD_Eldredge2007.dat"), "Eldredge"), 1, 4, 0.02);
  c.d_li = compare_history(tau, cd, read_coefficient_history(ref("CD_Li2015.dat"), "Li"), 1, 4, 0.02);
  std::printf("  2-D hovering wing, c/%.0f, ratio %.2f, %d x %d x %d cells, %ld steps, %.1f s; L_max %.4f D_max %.4f\n",
              r.settings.cells_per_chord, r.settings.stretch_ratio, r.nx, r.ny, r.nz, r.steps, r.seconds,
              r.normalisation.lift, r.normalisation.drag);
  for (std::size_t k = 0; k < r.cycle_cl.size(); ++k)
    std::printf("    cycle %zu: C_L %.4f C_D %.4f (surface integral C_L %.4f C_D %.4f)\n", k + 1, r.cycle_cl[k],
                r.cycle_cd[k], r.cycle_cl_surface[k], r.cycle_cd_surface[k]);
  std::printf("    cycles 2-4: C_L %.4f (surface %.4f), C_D %.4f; spanwise deviation %.2e U_max\n", c.cl, c.cl_surface,
              c.cd, r.spanwise_deviation);
  std::printf("    cycles 2-4 under the translational normalisation (1/2 U_max^2 c x 1.2, x 1.4): C_L %.4f, C_D %.4f\n",
              c.cl * r.normalisation.lift / r.normalisation.lift_translational,
              c.cd * r.normalisation.drag / r.normalisation.drag_translational);
  auto line = [](const char* what, const HistoryComparison& h) {
    std::printf("    %-22s reference mean %.4f, correlation %.3f, rms difference %.3f (%d points)\n", what,
                h.reference_mean, h.correlation, h.rms_difference, h.points);
  };
  line("C_L vs experiment", c.l_exp), line("C_L vs Eldredge 2007", c.l_el), line("C_L vs Li 2015", c.l_li);
  line("C_D vs experiment", c.d_exp), line("C_D vs Eldredge 2007", c.d_el), line("C_D vs Li 2015", c.d_li);
  return c;
}

Hovering2dResult run(double cells_per_chord, int span_cells = 2) {
  Hovering2dCase c;
  c.cells_per_chord = cells_per_chord;
  c.span_cells = span_cells;
  if (const char* v = std::getenv("H2D_CYCLES")) c.cycles = std::atof(v);
  if (const char* v = std::getenv("H2D_HALF_WIDTH")) c.half_width = std::atof(v);
  if (const char* v = std::getenv("H2D_RE")) c.reynolds = std::atof(v);
  if (const char* v = std::getenv("H2D_THICKNESS")) c.thickness = std::atof(v);
  if (const char* v = std::getenv("H2D_STRETCH")) c.stretch_ratio = std::atof(v);
  if (const char* v = std::getenv("H2D_HYPRE")) c.hypre = std::atoi(v) != 0;
  return run_hovering_2d(c);
}

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : fallback;
}

// Any grid (H2D_CPC cells per chord, H2D_NZ span cells, H2D_CYCLES periods) and case (H2D_HALF_WIDTH of the walled
// box, H2D_RE, H2D_THICKNESS of the chord, H2D_STRETCH ratio outside the fine box; H2D_HYPRE=1: hypre's pressure
// solver, which converges in boxes beyond +-22 c where the multigrid stalls), printed, not asserted.
TEST(Hovering2d, DISABLED_Probe) {
  compare(run(env_int("H2D_CPC", 16), env_int("H2D_NZ", 2)));
}

// A slab of four cells stays 2-D: the spanwise velocity and the spanwise variation of u, v after a quarter period
// stay at the Poisson tolerance's level (4.8e-5 U_max measured). Regression test of the immersed boundary on a
// periodic axis: the last layer's cells used to miss the image of their upper face among the forced faces, so no
// cell of that layer was ever "fully forced" and its pressure was never extended; the layer then drifted from the
// others and the deviation reached 0.25 U_max within this quarter period.
TEST(Hovering2d, FlowStaysTwoDimensionalInAThickerSlab) {
  Hovering2dCase c;
  c.cells_per_chord = 16;
  c.span_cells = 4;
  c.cycles = 0.25;
  const Hovering2dResult r = run_hovering_2d(c);
  std::printf("  c/16, 4 span cells, a quarter period: spanwise deviation %.2e U_max\n", r.spanwise_deviation);
  EXPECT_LT(r.spanwise_deviation, 1e-3);
}

// The targets on the converged grid: mean C_L of cycles 2-4 within 5 % of the CFD pair (Eldredge 2007,
// Li et al. 2015) and within 15 % of the measurement.
void check_targets(const Comparison& c, double cfd_tolerance, double experiment_tolerance) {
  const double lo = std::min(c.l_el.reference_mean, c.l_li.reference_mean);
  const double hi = std::max(c.l_el.reference_mean, c.l_li.reference_mean);
  EXPECT_GE(c.cl, (1 - cfd_tolerance) * lo);
  EXPECT_LE(c.cl, (1 + cfd_tolerance) * hi);
  EXPECT_NEAR(c.cl / c.l_exp.reference_mean, 1.0, experiment_tolerance);
}

// CI: c/16 in the fine box (the published CFD used c/40), a two-cell slab, four cycles, about 10 s on one
// thread. Measured: mean C_L of cycles 2-4 0.4415 (Li et al. 0.4898, Eldredge 0.4963, experiment 0.4473),
// lift correlation with Li et al. 0.975, drag 0.986, mean C_D 0.697 (Li et al. 0.752). Tolerances from the grid
// study (docs/validation.md, "2-D hovering wing"): c/32 reads 0.4536 (2.7 % above c/16; -7.4 % from Li et al.,
// +1.4 % from the measurement, correlations 0.979 and 0.990); asserted: within 12 % of the
// CFD pair (the converged target of 5 % does not hold on this grid, nor on c/32: recorded, not hidden),
// within 15 % of the measurement (the target), the histories' shape (correlation with Li et al. above
// 0.95 for lift and drag), mean C_D within 10 % of Li et al., and the flow 2-D.
TEST(Hovering2d, CoarseGridAgainstThePublishedHistories) {
  const Hovering2dResult r = run(16);
  const Comparison c = compare(r);
  EXPECT_LT(r.spanwise_deviation, 1e-3);
  check_targets(c, 0.12, 0.15);
  EXPECT_GT(c.l_li.correlation, 0.95);
  EXPECT_GT(c.d_li.correlation, 0.95);
  EXPECT_NEAR(c.cd / c.d_li.reference_mean, 1.0, 0.10);
}

// Converged grid, the targets: run with
//   OMP_NUM_THREADS=2 ./build/tests/test_cfd --gtest_also_run_disabled_tests --gtest_filter='Hovering2d.DISABLED_Converged*'
TEST(Hovering2d, DISABLED_ConvergedC32) { check_targets(compare(run(32)), 0.05, 0.15); }

}  // namespace
