// Tests for cfd/navier_stokes/run: the plan (grid around the swept volume, checks), forces.csv, checkpoints and
// exact restart, divergence handling.
#include <gtest/gtest.h>
#include <functional>
#include <initializer_list>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <cstring>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include "cfd/navier_stokes/insect_motion.hpp"
#include <hdf5.h>
#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "cfd/navier_stokes/run.hpp"
#include "common/expect_error.hpp"
#include "common/case_text.hpp"
#include "core/configuration.hpp"
#include "cfd/navier_stokes/geometry.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {
namespace {

namespace fs = std::filesystem;

// The test moth with an [aero.cfd] table (inserted before [trim]).
std::string cfd_case_text(const std::string& cfd_keys) {
  return testing::replace(testing::valid_cfd_case_text(), "[trim]\n", "[aero.cfd]\n" + cfd_keys + "\n[trim]\n");
}

Case cfd_case(const std::string& name, const std::string& cfd_keys) {
  return load_case(testing::write_temp(name, cfd_case_text(cfd_keys)));
}

// A tiny grid: 4 cells per mean chord, no far field beyond a fine box 0.4 R around the swept volume.
const char* tiny_keys =
    "cells_per_chord = 4\nfine_margin_R = 0.4\nupstream_R = 0\ndownstream_R = 0\nlateral_R = 0\nabove_R = 0\n"
    "below_R = 0\nsteps_per_cycle = 60\nfields_per_cycle = 3\nsurfaces_per_cycle = 0\ncheckpoints_per_cycle = 6\n"
    "threads = 1\n";

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string fresh_dir(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("flapstab_run_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  return d.string();
}

Vec3 swirl(double x, double y, double z) {
  const double k = 40.0;  // 1/m
  return Vec3(0.5 * std::sin(k * z), 0.5 * std::cos(k * x), 0.3 * std::sin(k * y));
}

TEST(CfdPlan, GridHoldsTheSweptVolumeAtTheRequestedSpacing) {
  const Case c = cfd_case("plan.toml", "cells_per_chord = 10\nstretch_ratio = 1.06\nbelow_R = 2\n");
  const CfdPlan p = plan_cfd(c, c.kinematics, BodyMotion{});
  // Every wing and body vertex over a wingbeat lies inside the swept box, which lies inside the fine box.
  const Configuration config(c.insect, c.kinematics);
  const InsectSurfaces surf(config, MeshResolution{16, 40, 10});
  for (int k = 0; k < 20; ++k)
    for (const auto& part : surf.at(c.kinematics.period() * (k + 0.37) / 20))
      for (const Vec3& v : part.mesh.vertices)
        for (int d = 0; d < 3; ++d) {
          EXPECT_GE(v[d], p.fine_lo[d]);
          EXPECT_LE(v[d], p.fine_hi[d]);
        }
  const double R = c.insect.wing.length, h = c.insect.wing.mean_chord / 10;
  EXPECT_DOUBLE_EQ(p.h, h);
  EXPECT_LE(p.h_actual, h * (1 + 1e-12));
  EXPECT_GT(p.h_actual, 0.85 * h);
  EXPECT_NEAR(p.chord_cells, c.insect.wing.mean_chord / p.h_actual, 1e-12);
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(p.fine_lo[d], p.swept_lo[d] - 0.1 * R, 1e-12);
    EXPECT_NEAR(p.fine_hi[d], p.swept_hi[d] + 0.1 * R, 1e-12);
    const Axis a = Axis::stretched(p.axes[std::size_t(d)], false);
    EXPECT_LE(a.max_ratio(), 1.06 * (1 + 1e-9));
    EXPECT_EQ(a.n % 8, 0);
    EXPECT_DOUBLE_EQ(a.lo, p.domain_lo[d]);
    EXPECT_DOUBLE_EQ(a.hi, p.domain_hi[d]);
  }
  EXPECT_NEAR(p.domain_hi.z() - p.fine_hi.z(), 2 * R, 1e-12);  // below_R
  EXPECT_NEAR(p.fine_lo.z() - p.domain_lo.z(), 3 * R, 1e-12);  // above_R default
  // The body's mean centre is O: the swept box straddles the origin.
  for (int d = 0; d < 3; ++d) {
    EXPECT_LT(p.swept_lo[d], 0.0);
    EXPECT_GT(p.swept_hi[d], 0.0);
  }
  // Reynolds number from the fluid's viscosity: U_ref = 2 Phi f R, L_ref = mean chord.
  const double U = 2 * c.kinematics.stroke_amplitude() * c.kinematics.frequency_hz * R;
  EXPECT_NEAR(p.reynolds, U * c.insect.wing.mean_chord / c.fluid.kinematic_viscosity, 1e-9 * p.reynolds);
  EXPECT_TRUE(p.warnings.empty());
}

// A fine box re-planned on the lattice (a free flight's body drifting): each face moves by whole fine cells, the
// fine faces of the two grids coincide where the boxes overlap (to rounding), the stretched cells and the domain
// keep their distances from the box, and fine_box_shift finds the smallest box on the lattice holding a request.
TEST(CfdPlan, ShiftedFineBoxStaysOnTheLattice) {
  const Case c = cfd_case("shift.toml", "cells_per_chord = 6\nstretch_ratio = 1.06\nbelow_R = 2\n");
  const CfdPlan p = plan_cfd(c, c.kinematics, BodyMotion{});
  const FineBoxShift shift{{3, -2, 0}, {5, -2, 1}};
  const CfdPlan q = shifted_plan(p, shift);
  const Grid g0 = plan_grid(p), g1 = plan_grid(q);
  for (int d = 0; d < 3; ++d) {
    const Axis& a0 = g0.axis[std::size_t(d)];
    const Axis& a1 = g1.axis[std::size_t(d)];
    int n0 = 0, n1 = 0;
    for (int i = 1; i <= a0.n; ++i) n0 += a0.xc[std::size_t(i)] > p.fine_lo[d] && a0.xc[std::size_t(i)] < p.fine_hi[d];
    for (int i = 1; i <= a1.n; ++i) n1 += a1.xc[std::size_t(i)] > q.fine_lo[d] && a1.xc[std::size_t(i)] < q.fine_hi[d];
    const double h = (p.fine_hi[d] - p.fine_lo[d]) / n0;
    const int lo = shift.lo[std::size_t(d)], hi = shift.hi[std::size_t(d)];
    EXPECT_EQ(n1, n0 + hi - lo) << d;
    EXPECT_NEAR(q.fine_lo[d], p.fine_lo[d] + lo * h, 1e-12 * h) << d;
    EXPECT_NEAR(q.fine_hi[d], p.fine_hi[d] + hi * h, 1e-12 * h) << d;
    EXPECT_NEAR(q.domain_lo[d] - q.fine_lo[d], p.domain_lo[d] - p.fine_lo[d], 1e-12 * h) << d;
    EXPECT_NEAR(q.domain_hi[d] - q.fine_hi[d], p.domain_hi[d] - p.fine_hi[d], 1e-12 * h) << d;
    EXPECT_DOUBLE_EQ(a1.lo, q.domain_lo[d]);
    EXPECT_LE(a1.max_ratio(), 1.06 * (1 + 1e-9));
    EXPECT_EQ(a1.n % 8, 0);
    // Every face of the new fine box inside the old one is a face of the old grid.
    int matched = 0;
    for (int i = 1; i <= a1.n + 1; ++i) {
      const double x = a1.xf[std::size_t(i)];
      if (x < std::max(p.fine_lo[d], q.fine_lo[d]) - 1e-9 * h || x > std::min(p.fine_hi[d], q.fine_hi[d]) + 1e-9 * h)
        continue;
      double best = 1e300;
      for (int k = 1; k <= a0.n + 1; ++k) best = std::min(best, std::abs(a0.xf[std::size_t(k)] - x));
      EXPECT_LT(best, 1e-9 * h) << d << " face " << i;
      ++matched;
    }
    EXPECT_GE(matched, n0 - 5);
  }
  EXPECT_EQ(shifted_plan(p, FineBoxShift{}).fine_lo, p.fine_lo);
  EXPECT_TRUE(fine_box_shift(p, p.fine_lo, p.fine_hi).empty());
  // A request 2.3 cells inside the low faces and 0.5 cell inside the high ones, and one 1.2 cells beyond them.
  std::array<double, 3> h;
  for (int d = 0; d < 3; ++d) {
    const Axis& a0 = g0.axis[std::size_t(d)];
    int n0 = 0;
    for (int i = 1; i <= a0.n; ++i) n0 += a0.xc[std::size_t(i)] > p.fine_lo[d] && a0.xc[std::size_t(i)] < p.fine_hi[d];
    h[std::size_t(d)] = (p.fine_hi[d] - p.fine_lo[d]) / n0;
  }
  const Vec3 hv(h[0], h[1], h[2]);
  const FineBoxShift in = fine_box_shift(p, p.fine_lo + 2.3 * hv, p.fine_hi - 0.5 * hv);
  const FineBoxShift out = fine_box_shift(p, p.fine_lo - 1.2 * hv, p.fine_hi + 1.2 * hv);
  for (std::size_t d = 0; d < 3; ++d) {
    EXPECT_EQ(in.lo[d], 2);
    EXPECT_EQ(in.hi[d], 0);
    EXPECT_EQ(out.lo[d], -2);
    EXPECT_EQ(out.hi[d], 2);
  }
  EXPECT_THROW(shifted_plan(p, FineBoxShift{{0, 0, 0}, {-100000, 0, 0}}), std::invalid_argument);
}

// The flow carried to another grid (transfer_state): linear velocity components and pressure are reproduced exactly
// (trilinear interpolation) wherever the new point lies within the old lattice, the new grid's points beyond the old
// domain get still air, the same grid gives the state back bit for bit, and the Poisson guesses are dropped.
TEST(CfdPlan, TransferredStateReproducesLinearFieldsAndStillAirOutside) {
  StretchedAxis sa;
  sa.lo = -1;
  sa.hi = 1.5;
  sa.box_lo = -0.4;
  sa.box_hi = 0.6;
  sa.h = 0.05;
  sa.max_ratio = 1.08;
  StretchedAxis sb = sa;  // shifted by 0.37 and with a finer box: the lattices do not coincide
  sb.lo += 0.37;
  sb.hi += 0.37;
  sb.box_lo += 0.37;
  sb.box_hi += 0.37;
  sb.h = 0.043;
  const Grid from(Axis::stretched(sa, false), Axis::stretched(sa, false), Axis::stretched(sa, false));
  const Grid to(Axis::stretched(sb, false), Axis::stretched(sa, false), Axis::stretched(sb, false));
  auto lin = [](int d, const std::array<double, 3>& x) { return 1 + d + 2 * x[0] - 3 * x[1] + 0.5 * x[2]; };
  SimulationState s;
  s.time = 0.25;
  s.step = 17;
  s.dt_last = 1e-3;
  s.guess = true;
  const Shape sh = from.shape();
  s.u = VectorField(sh);
  s.phi = VectorField(sh);
  s.p = Field(sh);
  for (int k = 0; k <= sh.nz + 1; ++k)
    for (int j = 0; j <= sh.ny + 1; ++j)
      for (int i = 0; i <= sh.nx + 1; ++i) {
        for (int d = 0; d < 3; ++d) s.u[d](i, j, k) = lin(d, from.point(d, i, j, k));
        s.p(i, j, k) = lin(5, from.centre(i, j, k));
        s.phi[0](i, j, k) = 1;
      }
  const SimulationState t = transfer_state(s, from, to);
  EXPECT_EQ(t.time, s.time);
  EXPECT_EQ(t.step, s.step);
  EXPECT_EQ(t.dt_last, s.dt_last);
  EXPECT_FALSE(t.guess);
  // Within the old lattice of each component: exact; beyond the old domain: zero.
  auto within = [&](int d, const std::array<double, 3>& x) {
    for (int a = 0; a < 3; ++a) {
      const Axis& ax = from.axis[std::size_t(a)];
      const double first = a == d ? ax.xf[1] : ax.xc[1];
      const double last = a == d ? ax.xf[std::size_t(ax.n + 1)] : ax.xc[std::size_t(ax.n)];
      if (x[std::size_t(a)] < first || x[std::size_t(a)] > last) return false;
    }
    return true;
  };
  auto beyond = [&](const std::array<double, 3>& x) {
    for (int a = 0; a < 3; ++a) {
      const Axis& ax = from.axis[std::size_t(a)];
      if (x[std::size_t(a)] < ax.lo - 1e-9 || x[std::size_t(a)] > ax.hi + 1e-9) return true;
    }
    return false;
  };
  const Shape ts = to.shape();
  double worst = 0;
  long exact = 0, outside = 0;
  for (int k = 0; k <= ts.nz + 1; ++k)
    for (int j = 0; j <= ts.ny + 1; ++j)
      for (int i = 0; i <= ts.nx + 1; ++i) {
        for (int d = 0; d < 3; ++d) {
          const auto x = to.point(d, i, j, k);
          if (beyond(x)) {
            EXPECT_EQ(t.u[d](i, j, k), 0.0);
            ++outside;
          } else if (within(d, x)) {
            worst = std::max(worst, std::abs(t.u[d](i, j, k) - lin(d, x)));
            ++exact;
          }
        }
        const auto xc = to.centre(i, j, k);
        if (within(-1, xc)) worst = std::max(worst, std::abs(t.p(i, j, k) - lin(5, xc)));
        EXPECT_EQ(t.phi[0](i, j, k), 0.0);
      }
  std::printf("  transfer: %ld points within the old lattice, worst error %.2e; %ld beyond the old domain\n", exact,
              worst, outside);
  EXPECT_LT(worst, 1e-12);
  EXPECT_GT(exact, 1000);
  EXPECT_GT(outside, 100);
  // The same grid: the interior values back bit for bit (ghosts take the nearest interior value or still air).
  const SimulationState same = transfer_state(s, from, from);
  for (int k = 1; k <= sh.nz; ++k)
    for (int j = 1; j <= sh.ny; ++j)
      for (int i = 1; i <= sh.nx; ++i) {
        for (int d = 0; d < 3; ++d) ASSERT_EQ(same.u[d](i, j, k), s.u[d](i, j, k));
        ASSERT_EQ(same.p(i, j, k), s.p(i, j, k));
      }
  const Grid other(Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false));
  EXPECT_THROW(transfer_state(s, other, from), std::invalid_argument);  // the state is not of `other`
}

// A field series whose grid changes (a free flight's re-planned fine box): the writer starts again on the new grid
// and the series lists both files, each with its own dimensions.
TEST(CfdPlan, FieldSeriesFollowsAReplannedGrid) {
  const Case c = cfd_case("series.toml", tiny_keys);
  const CfdPlan p = plan_cfd(c, c.kinematics, BodyMotion{});
  const Vec3 shift_by = Vec3::Constant(0.1 * c.insect.wing.length);
  const CfdPlan q = shifted_plan(p, fine_box_shift(p, p.fine_lo + shift_by, p.fine_hi + shift_by));
  Simulation a(c, c.kinematics, BodyMotion{}, p), b(c, c.kinematics, BodyMotion{}, q);
  ASSERT_NE(a.grid().shape(), b.grid().shape());
  const std::string dir = fresh_dir("series");
  FieldOutput out(dir, 1, FieldPrecision::float32);
  out.write(a);
  b.advance();
  out.write(b);
  const std::string xmf = read_text(dir + "/fields.xmf");
  for (const Simulation* sim : {&a, &b}) {
    const Shape sh = sim->grid().shape();
    const std::string dims = fmt::format("Dimensions=\"{} {} {}\"", sh.nz + 1, sh.ny + 1, sh.nx + 1);
    EXPECT_NE(xmf.find(dims), std::string::npos) << dims << "\n" << xmf.substr(0, 2000);
  }
}

TEST(CfdPlan, ReynoldsOverridesTheViscosity) {
  const Case c = cfd_case("re.toml", "reynolds = 250\n");
  const CfdPlan p = plan_cfd(c, c.kinematics, BodyMotion{});
  EXPECT_DOUBLE_EQ(p.reynolds, 250);
  EXPECT_NEAR(p.nu, p.u_ref * p.l_ref / 250, 1e-15);
}

// The grid is fixed to the body: a body motion does not move the insect in it, so the hover and every perturbed
// run share one grid; the far field's speed enters the fixed step's CFL estimate.
TEST(CfdPlan, BodyMotionKeepsTheGridAndRaisesTheFarFieldSpeed) {
  const Case c = cfd_case("rot.toml", "cycles = 2\nsteps_per_cycle = 400\n");
  const CfdPlan still = plan_cfd(c, c.kinematics, BodyMotion{});
  BodyMotion m;
  m.velocity = Vec3(0.3, 0, 0);
  m.rate = Vec3(0, 5.0, 0);
  const CfdPlan moving = plan_cfd(c, c.kinematics, m);
  EXPECT_EQ(grid_summary(plan_grid(moving)), grid_summary(plan_grid(still)));
  EXPECT_EQ(still.body_speed_max, 0.0);
  // |V| + |Omega| times the farthest corner of the swept box from O
  double r = 0;
  for (int k = 0; k < 8; ++k)
    r = std::max(r, Vec3(k & 1 ? still.swept_hi.x() : still.swept_lo.x(), k & 2 ? still.swept_hi.y() : still.swept_lo.y(),
                         k & 4 ? still.swept_hi.z() : still.swept_lo.z()).norm());
  EXPECT_NEAR(moving.body_speed_max, 0.3 + 5.0 * r, 1e-12);
}

TEST(CfdPlan, PartOutsideTheDomainIsAnInputErrorNamingTheMargin) {
  const Case c = cfd_case("out.toml", "fine_margin_R = 0\nbelow_R = 0\n");
  const std::string what =
      testing::expect_input_error([&] { plan_cfd(c, c.kinematics, BodyMotion{}); }, "aero.cfd.below_R", c.path);
  EXPECT_NE(what.find("leaves the domain"), std::string::npos);
  // Enough margin on that face: fine.
  const Case ok = cfd_case("out2.toml", "fine_margin_R = 0\nbelow_R = 0.5\n");
  EXPECT_NO_THROW(plan_cfd(ok, ok.kinematics, BodyMotion{}));
}

TEST(CfdPlan, UnderResolvedChordIsAnErrorBelowFourCellsAndAWarningBelowEight) {
  const Case bad = cfd_case("chord3.toml", "cells_per_chord = 3\n");
  testing::expect_input_error([&] { plan_cfd(bad, bad.kinematics, BodyMotion{}); }, "aero.cfd.cells_per_chord");
  // By wing length: R / 8 is 2.8 cells per chord for this moth (c / R = 0.35).
  const Case bad2 = cfd_case("chordR.toml", "cells_per_wing_length = 8\n");
  testing::expect_input_error([&] { plan_cfd(bad2, bad2.kinematics, BodyMotion{}); }, "aero.cfd.cells_per_wing_length");
  const Case rough = cfd_case("chord6.toml", "cells_per_chord = 6\n");
  const CfdPlan p = plan_cfd(rough, rough.kinematics, BodyMotion{});
  ASSERT_EQ(p.warnings.size(), 1u);
  EXPECT_NE(p.warnings[0].find("cells_per_chord"), std::string::npos);
}

// Wings that cut through each other are refused: the test moth's elliptic wings (widest chord, 1.27 c_bar, at the
// hinge 4 mm from the mid-plane) sweep their trailing edges across the plane of symmetry behind the body, where the
// immersed boundary would force the fluid caught in the overlap both ways (the hawkmoth's runs at 12 and 16 cells
// per chord blew up there, docs/validation.md). The same moth with a narrow wing base (valid_cfd_case_text) plans.
TEST(CfdPlan, WingsThatCutThroughEachOtherAreAnInputError) {
  const std::string keys = "[aero.cfd]\n" + std::string(tiny_keys) + "\n[trim]\n";
  const Case crossing =
      load_case(testing::write_temp("cross.toml", testing::replace(testing::valid_case_text(), "[trim]\n", keys)));
  const std::string what =
      testing::expect_input_error([&] { plan_cfd(crossing, crossing.kinematics, BodyMotion{}); }, "wing");
  EXPECT_NE(what.find("the left wing meets the right wing at t/T = "), std::string::npos) << what;
  EXPECT_NE(what.find("cut through each other"), std::string::npos) << what;
  EXPECT_NE(what.find("(the right wing reaches y = -"), std::string::npos) << what;
  EXPECT_NE(what.find("wing.planform"), std::string::npos) << what;
  const Case narrow = cfd_case("narrow.toml", tiny_keys);
  EXPECT_NO_THROW(plan_cfd(narrow, narrow.kinematics, BodyMotion{}));
}

// One header row with the units in the column names: pandas.read_csv(path) and csv.DictReader read it with no
// options (axes and parts are described in run.json).
// The case hash (checkpoints, the CFD model's kept runs) covers what the flow depends on: a comment, a changed
// derivative step or output directory keep it; a changed Reynolds number, grid or wing does not.
TEST(CfdRun, CaseHashIgnoresCommentsAndTheTablesTheFlowDoesNotDependOn) {
  using flapstab::testing::valid_case_text;
  using flapstab::testing::write_temp;
  const std::string base = valid_case_text() + "\n[aero.cfd]\ncells_per_chord = 8\n";
  auto hash = [](const std::string& name, const std::string& text) { return case_hash(write_temp(name, text)); };
  const std::string h0 = hash("hash0.toml", base);
  EXPECT_EQ(hash("hash1.toml", "# a comment\n" + base + "# another\n"), h0);
  EXPECT_EQ(hash("hash2.toml", base + "\n[derivatives]\nrelative_step = 0.02\n[output]\ndirectory = \"elsewhere\"\n"), h0);
  EXPECT_NE(hash("hash3.toml", valid_case_text() + "\n[aero.cfd]\ncells_per_chord = 12\n"), h0);
  EXPECT_NE(hash("hash4.toml", base + "reynolds = 150\n"), h0);
  std::string other = base;
  other.replace(other.find("mean_chord_m = 0.01826"), 22, "mean_chord_m = 0.01827");
  EXPECT_NE(hash("hash5.toml", other), h0);
  // Values are re-serialised exactly (17 significant digits): a change in the 14th digit counts.
  other = base;
  other.replace(other.find("mass_kg = 1.554e-3"), 18, "mass_kg = 1.5540000000001e-3");
  EXPECT_NE(hash("hash8.toml", other), h0);
  // Not TOML: the bytes.
  EXPECT_NE(hash("hash6.toml", "not toml ["), hash("hash7.toml", "not toml [["));
}

TEST(CfdRun, ForcesCsvHasOneHeaderRowWithUnitsInTheColumnNames) {
  const std::string h = forces_csv_header();
  ASSERT_EQ(std::count(h.begin(), h.end(), '\n'), 1);
  EXPECT_EQ(h.find('#'), std::string::npos);
  const std::string cols = h.substr(0, h.size() - 1);
  EXPECT_EQ(cols.rfind("time_s,step,phase,body_Fx_p_N", 0), 0u);
  for (const char* c : {"right_Fz_v_N", "left_My_p_N_m", "body_P_W", "Fz_N", "Mz_N_m", "wing_power_W"})
    EXPECT_NE(cols.find(c), std::string::npos) << c;
  CfdLoadRow r;
  r.time = 0.1;
  r.step = 3;
  r.part[1].pressure_force = Vec3(1, 2, 3);
  r.part[2].viscous_moment = Vec3(0, 0, 1.0 / 3);
  const std::string row = forces_csv_row(r);
  EXPECT_EQ(std::count(row.begin(), row.end(), ','), std::count(cols.begin(), cols.end(), ','));
  EXPECT_NE(row.find("0.33333333333333331"), std::string::npos);  // 17 significant digits: exact round trip
  EXPECT_EQ(r.total().force, Vec3(1, 2, 3));
  r.wing_power = -2.5e-7;
  r.part[0].power = 1e-300;
  std::string text = forces_csv_row(r);
  text.pop_back();
  const CfdLoadRow back = parse_forces_csv_row(text);
  EXPECT_EQ(forces_csv_row(back), forces_csv_row(r));
  EXPECT_EQ(back.step, 3);
  EXPECT_EQ(back.part[2].viscous_moment.z(), 1.0 / 3);
  EXPECT_EQ(back.parts, 3);
  EXPECT_THROW(parse_forces_csv_row("1,2,3"), std::invalid_argument);

  // A four-winged insect's rows: five parts (hind_right, hind_left after the fore pair), 13 columns more each; the
  // parser tells the two apart by the column count, and the total holds the hind pair's loads.
  const std::string h5 = forces_csv_header(5);
  EXPECT_EQ(h5.rfind(cols, 0), std::string::npos);  // the totals follow the hind pair, not the left wing
  EXPECT_EQ(h5.rfind(cols.substr(0, cols.find(",Fx_N")), 0), 0u);
  for (const char* c : {"hind_right_Fx_p_N", "hind_right_P_W", "hind_left_Mz_v_N_m", "hind_left_P_W"})
    EXPECT_NE(h5.find(std::string(",") + c), std::string::npos) << c;
  EXPECT_EQ(std::count(h5.begin(), h5.end(), ','), std::count(cols.begin(), cols.end(), ',') + 2 * 13);
  r.parts = 5;
  r.part[4].pressure_force = Vec3(0, -2, 0);
  const std::string row5 = forces_csv_row(r);
  EXPECT_EQ(std::count(row5.begin(), row5.end(), ','), std::count(h5.begin(), h5.end(), ','));
  EXPECT_EQ(r.total().force, Vec3(1, 0, 3));
  const CfdLoadRow back5 = parse_forces_csv_row(row5.substr(0, row5.size() - 1));
  EXPECT_EQ(back5.parts, 5);
  EXPECT_EQ(back5.part[4].pressure_force, Vec3(0, -2, 0));
  EXPECT_EQ(forces_csv_row(back5), row5);
  // Four parts' worth of columns is no geometry's.
  const std::string four_parts = row5.substr(0, row5.size() - 1);
  std::string cut = four_parts;
  for (int k = 0; k < 13; ++k) cut = cut.substr(0, cut.rfind(','));
  EXPECT_THROW(parse_forces_csv_row(cut), std::invalid_argument);
}

// Body-free flow in the insect's box: checkpoints every 10 steps; an interrupted run restarted from its newest
// checkpoint reproduces the uninterrupted one bit for bit (forces.csv rows and the final state).
TEST(CfdRun, RestartReproducesTheUninterruptedRunExactly) {
  const Case c = cfd_case("restart.toml", tiny_keys);
  CfdRunOptions o;
  o.bodies = false;
  o.initial_velocity = swirl;
  o.directory = fresh_dir("whole");
  const CfdResult whole = run_cfd(c, c.kinematics, BodyMotion{}, o);
  EXPECT_EQ(whole.steps, 60);
  EXPECT_GT(whole.cells, 0u);
  EXPECT_GT(whole.bytes, 100 * whole.cells);

  CfdRunOptions a = o;
  a.directory = fresh_dir("pieces");
  a.stop_after_steps = 25;
  const CfdResult first = run_cfd(c, c.kinematics, BodyMotion{}, a);
  EXPECT_EQ(first.steps, 25);
  EXPECT_FALSE(fs::exists(a.directory + "/run.json"));
  // forces.csv holds the rows to step 25; the checkpoints at steps 10 and 20 are the last two kept.
  {
    std::istringstream in(read_text(a.directory + "/forces.csv"));
    std::string line, last;
    int rows = 0;
    while (std::getline(in, line))
      if (line.rfind("time_s", 0) != 0) ++rows, last = line;
    EXPECT_EQ(rows, 25);
    EXPECT_NE(last.find(",25,"), std::string::npos);
  }
  EXPECT_TRUE(fs::exists(a.directory + "/checkpoints/checkpoint_000000020.h5"));
  EXPECT_TRUE(fs::exists(a.directory + "/checkpoints/checkpoint_000000010.h5"));
  EXPECT_FALSE(fs::exists(a.directory + "/checkpoints/checkpoint_000000000.h5"));

  CfdRunOptions b = o;
  b.directory = a.directory;
  b.restart = true;
  b.initial_velocity = {};  // the state comes from the checkpoint
  const CfdResult second = run_cfd(c, c.kinematics, BodyMotion{}, b);
  EXPECT_EQ(second.start_step, 20);
  EXPECT_EQ(second.steps, 60);
  EXPECT_NE(second.restarted_from.find("checkpoint_000000020.h5"), std::string::npos);

  const std::string csv_whole = read_text(o.directory + "/forces.csv"), csv_pieces = read_text(a.directory + "/forces.csv");
  const std::string header = forces_csv_header();
  EXPECT_EQ(std::count(csv_whole.begin(), csv_whole.end(), '\n'), std::count(header.begin(), header.end(), '\n') + 60);
  EXPECT_EQ(csv_whole, csv_pieces);
  CheckpointReader x(o.directory + "/checkpoints/checkpoint_000000060.h5");
  CheckpointReader y(a.directory + "/checkpoints/checkpoint_000000060.h5");
  EXPECT_EQ(x.header().time, y.header().time);
  for (const char* name : {"u0", "u1", "u2", "p", "phi0", "phi1", "phi2"}) {
    const auto u = x.read(name), v = y.read(name);
    ASSERT_EQ(u.size(), v.size());
    EXPECT_EQ(0, std::memcmp(u.data(), v.data(), u.size() * sizeof(double))) << name;
  }
  // The flow did move (the comparison is not between zeros).
  double umax = 0;
  for (double v : x.read("u0")) umax = std::max(umax, std::abs(v));
  EXPECT_GT(umax, 0.05);
  // run.json and the flow fields.
  const std::string js = read_text(o.directory + "/run.json");
  for (const char* k : {"\"reynolds\"", "\"total_cells\"", "\"seconds_per_step\"", "\"mean_loads_last_cycle\""})
    EXPECT_NE(js.find(k), std::string::npos) << k;
  EXPECT_TRUE(fs::exists(o.directory + "/fields/fields.xmf"));
  const StoredField p = read_field(o.directory + "/fields/fields_000020.h5", "pressure");
  EXPECT_EQ(p.units, "Pa");
  const StoredField q = read_field(o.directory + "/fields/fields_000020.h5", "q_criterion");
  bool finite = true;
  for (double v : q.values) finite = finite && std::isfinite(v);
  EXPECT_TRUE(finite);
}

// The initial output holds the curl of the swirl (a gradient added by the projection has none): in cells at
// least two away from the walls, central differences give omega = (0.3 k cos ky, 0.5 k cos kz, -0.5 k sin kx).
TEST(CfdRun, VorticityOfTheInitialSwirl) {
  const Case c = cfd_case("vort.toml", tiny_keys);
  CfdRunOptions o;
  o.bodies = false;
  o.initial_velocity = swirl;
  o.directory = fresh_dir("vort");
  o.dry_run = false;
  o.stop_after_steps = 1;
  run_cfd(c, c.kinematics, BodyMotion{}, o);
  const std::string f = o.directory + "/fields/fields_000000.h5";
  const StoredField w = read_field(f, "vorticity");
  const StoredField q = read_field(f, "q_criterion");
  const RectilinearAxes ax = read_axes(f);
  ASSERT_EQ(w.components, 3);
  EXPECT_EQ(w.units, "1/s");
  const auto n = w.cells;
  const double k = 40.0;
  double worst = 0;
  std::size_t checked = 0;
  for (std::size_t kk = 2; kk + 2 < n[2]; ++kk)
    for (std::size_t j = 2; j + 2 < n[1]; ++j)
      for (std::size_t i = 2; i + 2 < n[0]; ++i) {
        const double x = 0.5 * (ax.x[i] + ax.x[i + 1]), y = 0.5 * (ax.y[j] + ax.y[j + 1]), z = 0.5 * (ax.z[kk] + ax.z[kk + 1]);
        const Vec3 exact(0.3 * k * std::cos(k * y), 0.5 * k * std::cos(k * z), -0.5 * k * std::sin(k * x));
        const std::size_t at = ((kk * n[1] + j) * n[0] + i) * 3;
        worst = std::max(worst, (Vec3(w.values[at], w.values[at + 1], w.values[at + 2]) - exact).norm());
        ++checked;
      }
  EXPECT_GT(checked, 1000u);
  EXPECT_LT(worst, 0.05 * 0.5 * k);  // second-order differences over ~4 cells per radian: a few per cent
  double qmax = 0;
  for (double v : q.values) qmax = std::max(qmax, std::abs(v));
  EXPECT_GT(qmax, 0.0);
}

// A steady body velocity V enters as the uniform stream -V through the box; without bodies it stays uniform.
TEST(CfdRun, BodyVelocityIsAUniformStreamThroughTheBox) {
  const Case c = cfd_case("stream.toml", tiny_keys);
  CfdRunOptions o;
  o.bodies = false;
  o.directory = fresh_dir("stream");
  o.stop_after_steps = 20;  // a flow-field output every 20 steps (fields_per_cycle = 3, 60 steps per cycle)
  BodyMotion m;
  m.velocity = Vec3(1.5, -0.5, 0.25);  // flying forward, to the left and down
  run_cfd(c, c.kinematics, m, o);
  for (const char* f : {"/fields/fields_000000.h5", "/fields/fields_000020.h5"}) {
    const StoredField u = read_field(o.directory + f, "velocity");
    double worst = 0;
    for (std::size_t n = 0; n < u.values.size() / 3; ++n)
      worst = std::max(worst, (Vec3(u.values[3 * n], u.values[3 * n + 1], u.values[3 * n + 2]) + m.velocity).norm());
    EXPECT_LT(worst, 1e-6) << f;  // float32 field files
    const StoredField p = read_field(o.directory + f, "pressure");
    double pmax = 0;
    for (double x : p.values) pmax = std::max(pmax, std::abs(x));
    EXPECT_LT(pmax, 1e-6) << f;
  }
}

// A damaged newest checkpoint (a crash while it was renamed into place cannot leave one, a full disk can) is
// skipped for the one before it; the result is still the uninterrupted run's.
TEST(CfdRun, RestartSkipsADamagedCheckpoint) {
  const Case c = cfd_case("damaged.toml", tiny_keys);
  CfdRunOptions o;
  o.bodies = false;
  o.initial_velocity = swirl;
  o.directory = fresh_dir("damaged_whole");
  run_cfd(c, c.kinematics, BodyMotion{}, o);
  CfdRunOptions a = o;
  a.directory = fresh_dir("damaged");
  a.stop_after_steps = 25;
  run_cfd(c, c.kinematics, BodyMotion{}, a);
  const std::string newest = a.directory + "/checkpoints/checkpoint_000000020.h5";
  fs::resize_file(newest, fs::file_size(newest) / 2);
  a.stop_after_steps = 0;
  a.restart = true;
  a.initial_velocity = {};
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, a);
  EXPECT_EQ(r.start_step, 10);
  EXPECT_EQ(read_text(o.directory + "/forces.csv"), read_text(a.directory + "/forces.csv"));
}

// A kill between forces.csv and the checkpoint cannot lose rows any more (the rows are written first); a restart
// whose forces.csv stops short of the checkpoint's step (lost rows), or that has none, or a damaged row, is bad
// input naming the file and the line, not a silent run with a wrong mean.
TEST(CfdRun, RestartRefusesMissingOrDamagedRows) {
  const Case c = cfd_case("rows.toml", tiny_keys);
  CfdRunOptions a;
  a.bodies = false;
  a.initial_velocity = swirl;
  a.directory = fresh_dir("rows");
  a.stop_after_steps = 25;  // checkpoints at 10 and 20
  run_cfd(c, c.kinematics, BodyMotion{}, a);
  const std::string csv = a.directory + "/forces.csv", whole = read_text(csv);
  CfdRunOptions b = a;
  b.stop_after_steps = 0;
  b.restart = true;
  b.initial_velocity = {};
  // Rows only to step 15 (the checkpoint is at 20).
  std::string cut;
  {
    std::istringstream in(whole);
    std::string line;
    for (int n = 0; n <= 15 && std::getline(in, line); ++n) cut += line + "\n";  // the header and steps 1-15
  }
  std::ofstream(csv) << cut;
  std::string m = testing::expect_input_error([&] { run_cfd(c, c.kinematics, BodyMotion{}, b); }, "line 17", csv);
  EXPECT_NE(m.find("ends at step 15, before the checkpoint's step 20"), std::string::npos) << m;
  // A damaged row before the checkpoint.
  std::string damaged = whole;
  const auto at = damaged.find("\n", damaged.find("\n") + 1);  // end of the first data row
  damaged.insert(at, "x,y");
  std::ofstream(csv) << damaged;
  m = testing::expect_input_error([&] { run_cfd(c, c.kinematics, BodyMotion{}, b); }, "line 2", csv);
  EXPECT_NE(m.find("damaged row"), std::string::npos) << m;
  fs::remove(csv);
  m = testing::expect_input_error([&] { run_cfd(c, c.kinematics, BodyMotion{}, b); }, "", csv);
  EXPECT_NE(m.find("missing"), std::string::npos) << m;
  // Rows beyond the checkpoint (a kill after the rows, before the checkpoint) are dropped: the restart is exact.
  std::ofstream(csv) << whole;
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, b);
  EXPECT_EQ(r.start_step, 20);
  EXPECT_EQ(r.status, "complete");
}

// Every checkpoint array carries a checksum: a flipped value in the newest checkpoint is found on restart, which
// falls back to the checkpoint before it (and says why).
TEST(CfdRun, RestartVerifiesTheCheckpointChecksums) {
  const Case c = cfd_case("checksum.toml", tiny_keys);
  CfdRunOptions a;
  a.bodies = false;
  a.initial_velocity = swirl;
  a.directory = fresh_dir("checksum");
  a.stop_after_steps = 25;
  run_cfd(c, c.kinematics, BodyMotion{}, a);
  const std::string newest = a.directory + "/checkpoints/checkpoint_000000020.h5";
  {
    CheckpointReader ck(newest);
    EXPECT_NO_THROW(ck.verify());
  }
  {  // change one value of u1 in place, as a flipped bit on disk would
    const hid_t f = H5Fopen(newest.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    const hid_t set = H5Dopen2(f, "arrays/u1", H5P_DEFAULT);
    ASSERT_GE(set, 0);
    const hid_t space = H5Dget_space(set);
    hsize_t n = 0;
    H5Sget_simple_extent_dims(space, &n, nullptr);
    std::vector<double> v(std::size_t(H5Sget_simple_extent_npoints(space)));
    H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    v[v.size() / 2] = std::nextafter(v[v.size() / 2], 1e9);
    H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Sclose(space);
    H5Dclose(set);
    H5Fclose(f);
  }
  {
    CheckpointReader ck(newest);
    const std::string m = testing::expect_input_error([&] { ck.verify(); }, "u1", newest);
    EXPECT_NE(m.find("damaged"), std::string::npos) << m;
  }
  CfdRunOptions b = a;
  b.stop_after_steps = 0;
  b.restart = true;
  b.initial_velocity = {};
  std::ostringstream log;
  b.log = &log;
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, b);
  EXPECT_EQ(r.start_step, 10);
  EXPECT_NE(log.str().find("skipping " + newest), std::string::npos) << log.str();
  EXPECT_NE(log.str().find("damaged"), std::string::npos) << log.str();
}

// A restart of a finished run has nothing to do and rewrites nothing (run.json keeps the record of the run); a
// run stopped by `steps` (the CLI's --steps) leaves a checkpoint and run.json with status "stopped", and a restart
// finishes it; the finished run leaves no temporary file, and removes those of killed runs.
TEST(CfdRun, StoppedRunsContinueAndFinishedRunsAreLeftAlone) {
  const Case c = cfd_case("steps.toml", tiny_keys);
  CfdRunOptions a;
  a.bodies = false;
  a.initial_velocity = swirl;
  a.directory = fresh_dir("steps");
  a.steps = 7;
  const CfdResult first = run_cfd(c, c.kinematics, BodyMotion{}, a);
  EXPECT_EQ(first.status, "stopped");
  EXPECT_EQ(first.steps, 7);
  EXPECT_TRUE(fs::exists(a.directory + "/checkpoints/checkpoint_000000007.h5"));
  EXPECT_NE(read_text(a.directory + "/run.json").find("\"status\": \"stopped\""), std::string::npos);
  EXPECT_TRUE(first.result.available);
  EXPECT_TRUE(first.result.includes_startup);
  EXPECT_NE(first.result.note.find("less than a wingbeat"), std::string::npos);
  // A temporary file of a process that no longer runs (pid 2^22 + 1 is above Linux's default pid_max).
  const std::string stale = a.directory + "/checkpoints/checkpoint_000000099.h5.tmp.4194305";
  std::ofstream(stale) << "half";
  CfdRunOptions b = a;
  b.steps = 0;
  b.restart = true;
  b.initial_velocity = {};
  const CfdResult second = run_cfd(c, c.kinematics, BodyMotion{}, b);
  EXPECT_EQ(second.start_step, 7);
  EXPECT_EQ(second.steps, 60);
  EXPECT_EQ(second.status, "complete");
  EXPECT_FALSE(fs::exists(stale));
  const std::string json = read_text(a.directory + "/run.json");
  const auto stamp = fs::last_write_time(a.directory + "/run.json");
  const std::string rows = read_text(a.directory + "/forces.csv");
  EXPECT_EQ(std::count(rows.begin(), rows.end(), '\n'), 61);
  const CfdResult third = run_cfd(c, c.kinematics, BodyMotion{}, b);
  EXPECT_EQ(third.status, "nothing to do");
  EXPECT_EQ(read_text(a.directory + "/run.json"), json);
  EXPECT_EQ(fs::last_write_time(a.directory + "/run.json"), stamp);
  EXPECT_EQ(read_text(a.directory + "/forces.csv"), rows);
}

// The result of a run: the last complete wingbeat, the start-up wingbeat excluded (and said so when it is all
// there is). Rows of a made-up load history with a known mean per wingbeat.
TEST(CfdRun, ResultIsTheLastCompleteWingbeatWithoutTheStartUp) {
  CfdPlan plan;
  plan.period = 0.04;
  plan.steps_per_cycle = 40;
  std::vector<CfdLoadRow> rows;
  for (int k = 1; k <= 100; ++k) {  // 2.5 wingbeats
    CfdLoadRow r;
    r.step = k;
    r.time = k * 0.001;
    const int beat = int(std::ceil(r.time / plan.period - 1e-9));
    r.part[1].pressure_force = Vec3(0.1 * beat, 0, -1.0 * beat);  // mean F_z = -beat in wingbeat `beat`
    r.wing_power = 2.0;
    rows.push_back(r);
  }
  CfdRunResult res = cfd_run_result(rows, plan, 1.5);
  EXPECT_EQ(res.wingbeat, 2);
  EXPECT_TRUE(res.complete);
  EXPECT_FALSE(res.includes_startup);
  EXPECT_NEAR(res.from_s, 0.04, 1e-15);
  EXPECT_NEAR(res.to_s, 0.08, 1e-15);
  // The window holds the row at its start (the last of wingbeat 1, F_z = -1) and 40 rows of F_z = -2: the
  // trapezoid rule gives -2 + 0.5 * 1 / 40.
  EXPECT_NEAR(res.mean.force.z(), -2.0 + 0.5 / 40, 1e-12);
  EXPECT_NEAR(res.lift_over_weight, (2.0 - 0.5 / 40) / 1.5, 1e-12);
  EXPECT_NEAR(res.wing_power, 2.0, 1e-12);
  rows.resize(40);
  res = cfd_run_result(rows, plan, 1.5);
  EXPECT_EQ(res.wingbeat, 1);
  EXPECT_TRUE(res.includes_startup);
  EXPECT_NE(res.note.find("start-up"), std::string::npos);
  EXPECT_NE(cfd_run_result_text(res).find("lift / weight"), std::string::npos);
}

// A grid that cannot fit in memory is refused before anything is allocated, with the numbers.
TEST(CfdRun, AGridTooLargeForMemoryIsRefusedBeforeAllocation) {
  const Case c = cfd_case("huge.toml", tiny_keys);
  const CfdPlan plan = plan_cfd(c, c.kinematics, BodyMotion{});
  const Simulation sim(c, c.kinematics, BodyMotion{}, plan, {false, swirl});
  // The estimate bounds what the simulation holds (with the transient output arrays, within a factor 2).
  EXPECT_GE(double(estimated_bytes(plan)), double(sim.bytes()));
  EXPECT_LT(double(estimated_bytes(plan)), 2.0 * double(sim.bytes()) + double(64 << 20));
  const std::string m = testing::expect_input_error([&] { check_memory(plan, c.path, estimated_bytes(plan) / 2); },
                                                    "aero.cfd.cells_per_chord", c.path);
  EXPECT_NE(m.find("GiB of memory is available"), std::string::npos) << m;
  EXPECT_NO_THROW(check_memory(plan, c.path, 2 * estimated_bytes(plan)));
}

TEST(CfdRun, RestartRefusesAChangedCaseOrAnEmptyDirectory) {
  const std::string path = testing::write_temp("restart2.toml", cfd_case_text(tiny_keys));
  Case c = load_case(path);
  CfdRunOptions o;
  o.bodies = false;
  o.initial_velocity = swirl;
  o.directory = fresh_dir("changed");
  o.stop_after_steps = 12;
  run_cfd(c, c.kinematics, BodyMotion{}, o);
  o.stop_after_steps = 0;
  o.restart = true;
  {  // a change the flow depends on (a comment alone would not count: CaseHashIgnoresComments...)
    std::stringstream text;
    text << std::ifstream(path).rdbuf();
    std::string t = text.str();
    ASSERT_NE(t.find("mass_kg = 1.554e-3"), std::string::npos);
    t.replace(t.find("mass_kg = 1.554e-3"), 18, "mass_kg = 1.555e-3");
    std::ofstream(path) << t;
  }
  EXPECT_THROW(run_cfd(c, c.kinematics, BodyMotion{}, o), InputError);
  o.directory = fresh_dir("empty");
  EXPECT_THROW(run_cfd(c, c.kinematics, BodyMotion{}, o), InputError);
  EXPECT_FALSE(fs::exists(o.directory));
}

// Runs a case without bodies from the initial velocity u0 in a fresh directory; it must stop: a SolveError whose
// message names each of `expected`, the checkpoint of step 0 kept, no run.json.
void expect_run_stops(const Case& c, const std::string& dir, std::function<Vec3(double, double, double)> u0,
                      std::initializer_list<const char*> expected) {
  CfdRunOptions o;
  o.bodies = false;
  o.initial_velocity = std::move(u0);
  o.directory = fresh_dir(dir);
  try {
    run_cfd(c, c.kinematics, BodyMotion{}, o);
    ADD_FAILURE() << "expected SolveError";
  } catch (const SolveError& e) {
    const std::string m = e.what();
    for (const char* x : expected) EXPECT_NE(m.find(x), std::string::npos) << x << "\n" << m;
    EXPECT_NE(m.find("checkpoint_000000000.h5"), std::string::npos) << m;
  }
  EXPECT_TRUE(fs::exists(o.directory + "/checkpoints/checkpoint_000000000.h5"));
  EXPECT_FALSE(fs::exists(o.directory + "/run.json"));
}

// A fixed step far beyond the CFL limit of a 6 m/s swirl: the solver refuses it before the first step, and the
// run stops naming the step and the time.
TEST(CfdRun, UnstableStepStopsWithStepAndTimeAndKeepsTheCheckpoint) {
  // "-> Vec3": without it the lambda returns an Eigen expression that refers to swirl()'s dead temporary.
  expect_run_stops(cfd_case("unstable.toml", testing::replace(tiny_keys, "steps_per_cycle = 60", "steps_per_cycle = 4")),
                   "unstable", [](double x, double y, double z) -> Vec3 { return 12.0 * swirl(x, y, z); },
                   {"diverged at step 1 (t = 0 s, t/T = 0.0000)", "is unstable"});
}

// Non-finite values in the flow (here planted in the initial field of a stable run) stop the run at the end of
// the step that carries them (steps_per_cycle = 60: step 1 ends at t = T/60), naming the step and the time.
TEST(CfdRun, DivergenceStopsWithStepAndTimeAndKeepsTheCheckpoint) {
  const auto planted = [](double x, double y, double z) -> Vec3 {
    return std::sin(40.0 * z) > 0.9 ? Vec3(std::nan(""), 0.0, 0.0) : swirl(x, y, z);
  };
  expect_run_stops(cfd_case("diverge.toml", tiny_keys), "diverge", planted,
                   {"diverged at step 1 (t = 0.000641026 s, t/T = 0.0167)", "not finite"});
}

TEST(CfdRun, DryRunWritesNothing) {
  const Case c = cfd_case("dry.toml", tiny_keys);
  CfdRunOptions o;
  o.bodies = false;
  o.initial_velocity = swirl;
  o.directory = fresh_dir("dry");
  o.dry_run = true;
  std::ostringstream log;
  o.log = &log;
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, o);
  EXPECT_EQ(r.steps, 2);
  EXPECT_GT(r.seconds_per_step_estimate, 0);
  EXPECT_FALSE(fs::exists(o.directory));
  for (const char* k : {"cells", "bytes per cell", "MiB", "estimate (timed on the first 2 steps)", "Re = "})
    EXPECT_NE(log.str().find(k), std::string::npos) << k << "\n" << log.str();
}

// ---- with the immersed insect ----------------------------------------------------------------------------------

const char* tiny_moth_keys =
    "cells_per_chord = 4\nfine_margin_R = 0.4\nupstream_R = 0\ndownstream_R = 0\nlateral_R = 0\nabove_R = 0\n"
    "below_R = 0.5\nsteps_per_cycle = 400\nfields_per_cycle = 100\nsurfaces_per_cycle = 100\n"
    "checkpoints_per_cycle = 100\nbody_divisions = 6\nwing_span_stations = 12\nwing_chord_divisions = 4\nthreads = 1\n";

double wing_scale(const CfdLoadRow& r) {
  return (r.part[1].pressure_force + r.part[1].viscous_force).norm();
}

// The test moth's kinematics are symmetric: the left wing's loads mirror the right wing's in the x-z plane
// (force: x, z equal, y opposite; moment about O: x, z opposite, y equal). Surface-integrated loads within 0.1 % of
// the window's largest wing force, momentum-exchange loads within 0.2 % (both measured below 0.03 %). Before the
// faces on the mirror plane between the two wings' bands took both wings' values (docs/validation.md, "Mirror
// symmetry") this needed 3 % and 6 %.
TEST(CfdRunImmersed, TinyMothLoadsAreFiniteAndMirrorSymmetric) {
  for (const auto& [method, tol] : {std::pair<std::string, double>{"surface", 0.001}, {"exchange", 0.002}}) {
    SCOPED_TRACE(method);
    const Case c = cfd_case("moth_sym_" + method + ".toml", std::string(tiny_moth_keys) + "loads = \"" + method + "\"\n");
    CfdRunOptions o;
    o.stop_after_steps = 8;
    const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, o);
    ASSERT_EQ(r.rows.size(), 8u);
    // Scale: the largest wing force of the window (the impulsive start makes the first steps' loads large).
    double f = 0;
    for (const auto& row : r.rows) f = std::max(f, wing_scale(row));
    ASSERT_GT(f, 0);
    ASSERT_TRUE(std::isfinite(f));
    const double m = f * c.insect.wing.length;
    for (const auto& row : r.rows) {
      const auto& R = row.part[1];
      const auto& L = row.part[2];
      const Vec3 FR = R.pressure_force + R.viscous_force, FL = L.pressure_force + L.viscous_force;
      const Vec3 MR = R.pressure_moment + R.viscous_moment, ML = L.pressure_moment + L.viscous_moment;
      ASSERT_TRUE(FR.allFinite() && FL.allFinite() && MR.allFinite() && ML.allFinite());
      // A wrong mirror image (the left wing's pose or velocity) breaks these by the loads' own size.
      EXPECT_NEAR(FL.x(), FR.x(), tol * f) << row.step;
      EXPECT_NEAR(FL.y(), -FR.y(), tol * f) << row.step;
      EXPECT_NEAR(FL.z(), FR.z(), tol * f) << row.step;
      EXPECT_NEAR(ML.x(), -MR.x(), tol * m) << row.step;
      EXPECT_NEAR(ML.y(), MR.y(), tol * m) << row.step;
      EXPECT_NEAR(ML.z(), -MR.z(), tol * m) << row.step;
      // The body sits on the symmetry plane: its side force stays small.
      const Vec3 FB = row.part[0].pressure_force + row.part[0].viscous_force;
      EXPECT_LT(std::abs(FB.y()), tol * f) << row.step;
      EXPECT_TRUE(std::isfinite(row.wing_power));
    }
    // The wings do work on the air over the window.
    double work = 0;
    for (const auto& row : r.rows) work += row.wing_power;
    EXPECT_GT(work, 0.0);
  }
}

// Over its first wingbeat from rest the moth's wings lift: the mean vertical force points up (-z), a sizeable part
// of the weight on this coarse grid, and the wings do positive work on the air.
TEST(CfdRunImmersed, TinyMothLiftsOverAWingbeat) {
  const Case c = cfd_case("moth_lift.toml", testing::replace(tiny_moth_keys, "steps_per_cycle = 400", "steps_per_cycle = 200"));
  CfdRunOptions o;
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, o);
  ASSERT_EQ(r.last_cycle.size(), 200u);
  double fz = 0, power = 0;
  for (const auto& row : r.last_cycle) fz += row.total().force.z() / 200, power += row.wing_power / 200;
  const double weight = c.insect.total_mass() * 9.81;
  std::printf("  tiny moth, first wingbeat: mean Fz = %.4g N (weight %.4g N), mean wing power %.4g W\n", fz, weight, power);
  EXPECT_LT(fz, -0.2 * weight);
  EXPECT_GT(power, 0.0);
}

TEST(CfdRunImmersed, RestartWithTheInsectReproducesTheRowsExactly) {
  const Case c = cfd_case("moth_restart.toml", tiny_moth_keys);  // checkpoints every 4 steps
  CfdRunOptions o;
  o.directory = fresh_dir("moth_whole");
  o.stop_after_steps = 10;
  run_cfd(c, c.kinematics, BodyMotion{}, o);
  CfdRunOptions a = o;
  a.directory = fresh_dir("moth_pieces");
  a.stop_after_steps = 6;
  run_cfd(c, c.kinematics, BodyMotion{}, a);
  a.restart = true;
  a.stop_after_steps = 10;
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, a);
  EXPECT_EQ(r.start_step, 4);
  const std::string x = read_text(o.directory + "/forces.csv"), y = read_text(a.directory + "/forces.csv");
  EXPECT_EQ(x, y);
  const std::string header = forces_csv_header();
  EXPECT_EQ(std::count(x.begin(), x.end(), '\n'), std::count(header.begin(), header.end(), '\n') + 10);
  EXPECT_NE(x.find("\n"), std::string::npos);
  // Surfaces with pressure on both sides of the wings.
  EXPECT_TRUE(fs::exists(o.directory + "/surfaces/surfaces.pvd"));
  const std::string vtp = read_text(o.directory + "/surfaces/surfaces_right_000004.vtp");
  EXPECT_NE(vtp.find("pressure_back"), std::string::npos);
}

TEST(CfdRunImmersed, CfdModelReturnsTheLastCycleAboutO) {
  // Gentle wingbeat (stroke +-10 deg, pitch 90 +- 10 deg) at Re = 20: a whole wingbeat on the tiny grid.
  std::string text = cfd_case_text(testing::replace(tiny_moth_keys, "steps_per_cycle = 400", "steps_per_cycle = 60") +
                                   "reynolds = 20\n");
  text = testing::replace(testing::replace(text, "cos_deg = [-60.0]", "cos_deg = [-10.0]"), "sin_deg = [-55.0]",
                          "sin_deg = [-10.0]");
  Case c = load_case(testing::write_temp("moth_model.toml", text));
  const CfdModel model(c, nullptr);
  AeroRunOptions ro;
  ro.cycles = 1;
  ro.samples_per_cycle = 20;
  const WrenchHistory h = model.run(c.insect, c.kinematics, BodyMotion{}, ro);
  ASSERT_EQ(h.samples.size(), 20u);
  EXPECT_DOUBLE_EQ(h.samples[0].time, 0.0);
  EXPECT_NEAR(h.samples[19].time, 0.95 * c.kinematics.period(), 1e-15);
  for (const auto& s : h.samples) {
    EXPECT_TRUE(s.total().force.allFinite());
    EXPECT_TRUE(std::isfinite(s.power));
  }
  EXPECT_GT(std::abs(h.mean().force.z()), 0.0);
}


// ---- the stepping Simulation -----------------------------------------------------------------------------------

// The kinematics handed to the immersed boundary are analytic: the acceleration of every material point relative
// to the body's frame equals the central difference of its velocity; the apparent acceleration adds the Coriolis
// term 2 Omega x v (here a rolling, pitching and yawing body). Step 1e-6 T: difference error ~1e-9 relative.
TEST(CfdSimulation, InsectMotionAccelerationsAreTheDerivativesOfTheVelocities) {
  const Case c = cfd_case("motion_acc.toml", tiny_moth_keys);
  const Configuration config(c.insect, c.kinematics);
  const Vec3 W(3.0, -5.0, 2.0);
  const InsectMotion m(config, BodyMotion{Vec3(0.1, 0, 0.2), W});
  const double T = c.kinematics.period(), e = 1e-6 * T;
  for (double t : {0.013 * T, 0.37 * T, 0.81 * T}) {
    const auto now = m.parts(t), plus = m.parts(t + e), minus = m.parts(t - e);
    for (int i = 0; i < 3; ++i) {
      const PartState& s = now[std::size_t(i)];
      const Vec3 y(0.01, 0.03, -0.002);  // a material point (reference frame)
      const Vec3 x = s.pose.apply(y);
      const Vec3 fd = (plus[std::size_t(i)].velocity.at(plus[std::size_t(i)].pose.apply(y)) -
                       minus[std::size_t(i)].velocity.at(minus[std::size_t(i)].pose.apply(y))) / (2 * e);
      const Vec3 alpha = (plus[std::size_t(i)].velocity.omega - minus[std::size_t(i)].velocity.omega) / (2 * e);
      const double scale = std::max(1.0, fd.norm());
      EXPECT_EQ(s.frame_rate, W);
      EXPECT_LT((s.acceleration_at(x) - 2 * W.cross(s.velocity.at(x)) - fd).norm(), 1e-6 * scale)
          << "part " << i << " t/T " << t / T;
      EXPECT_LT((s.angular_acceleration - alpha).norm(), 1e-6 * std::max(1.0, alpha.norm())) << "part " << i;
      // The velocity field is the pose's derivative.
      const Vec3 dx = (plus[std::size_t(i)].pose.apply(y) - minus[std::size_t(i)].pose.apply(y)) / (2 * e);
      EXPECT_LT((s.velocity.at(x) - dx).norm(), 1e-6 * std::max(1.0, dx.norm())) << "part " << i;
    }
  }
}

// run_cfd is the loop over a Simulation and its observers: advancing a Simulation by hand with a ForcesCsv
// observer gives the same rows, bit for bit.
TEST(CfdSimulation, AdvancedByHandGivesTheRowsOfRunCfd) {
  const Case c = cfd_case("sim_by_hand.toml", tiny_moth_keys);
  CfdRunOptions o;
  o.stop_after_steps = 6;
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, o);
  const std::string path = fresh_dir("sim_by_hand") + "/forces.csv";
  fs::create_directories(fs::path(path).parent_path());
  Simulation sim(c, c.kinematics, BodyMotion{}, plan_cfd(c, c.kinematics, BodyMotion{}));
  ForcesCsv csv(path);
  for (int k = 0; k < 6; ++k) csv.on_step(sim, sim.advance());
  csv.on_end(sim);
  ASSERT_EQ(csv.rows().size(), r.rows.size());
  std::string expected = forces_csv_header();
  for (const auto& row : r.rows) expected += forces_csv_row(row);
  EXPECT_EQ(read_text(path), expected);
}

// Restoring a state taken in memory continues the run bit for bit (the kept periodic hover state relies on it).
TEST(CfdSimulation, RestoredStateContinuesBitForBit) {
  const Case c = cfd_case("sim_restore.toml", tiny_moth_keys);
  const CfdPlan plan = plan_cfd(c, c.kinematics, BodyMotion{});
  Simulation whole(c, c.kinematics, BodyMotion{}, plan);
  std::vector<std::string> a;
  for (int k = 0; k < 8; ++k) a.push_back(forces_csv_row(whole.advance().row));
  SimulationState mid;
  {
    Simulation first(c, c.kinematics, BodyMotion{}, plan);
    for (int k = 0; k < 5; ++k) first.advance();
    mid = first.state();
  }
  Simulation second(c, c.kinematics, BodyMotion{}, plan);
  second.restore(mid);
  EXPECT_EQ(second.step(), 5);
  for (int k = 5; k < 8; ++k) EXPECT_EQ(forces_csv_row(second.advance().row), a[std::size_t(k)]) << k;
  EXPECT_EQ(second.state().u[2].data()[1234], whole.state().u[2].data()[1234]);
}

// The sponge layer relaxes towards the far field of the run's own motion: the uniform stream -V, an exact solution,
// is left as it is to rounding (a layer relaxing towards still air would slow it by about V sigma t = 1.7 V here).
// Its width is checked against the room between the fine box and the faces; a partitioned run takes its force into
// the outer part.
TEST(CfdSimulation, SpongeLayerHoldsTheFarFieldStreamOfTheRun) {
  const char* keys = "cells_per_chord = 4\nfine_margin_R = 0.4\nupstream_R = 0.5\ndownstream_R = 0.5\nlateral_R = 0.5\n"
                     "above_R = 0.5\nbelow_R = 0.6\nsponge_R = 0.3\nsponge_rate = 10\nsteps_per_cycle = 60\n"
                     "threads = 1\n";
  const Case c = cfd_case("sponge.toml", keys);
  BodyMotion m;
  m.velocity = Vec3(0.4, 0.1, -0.3);
  const CfdPlan plan = plan_cfd(c, c.kinematics, m);
  EXPECT_NEAR(plan.sponge_width, 0.3 * c.insect.wing.length, 1e-15);
  EXPECT_NEAR(plan.sponge_rate * plan.period, 10, 1e-12);
  for (bool on : plan.sponge_faces) EXPECT_TRUE(on);  // every face by default
  SimulationOptions o;
  o.bodies = false;
  Simulation sim(c, c.kinematics, m, plan, o);
  for (int n = 0; n < 10; ++n) sim.advance();
  const Solver& sv = sim.solver();
  const Shape sh = sv.grid().shape();
  double err = 0;
  for (int d = 0; d < 3; ++d)
    for (int k = 1; k <= sh.nz; ++k)
      for (int j = 1; j <= sh.ny; ++j)
        for (int i = 1; i <= sh.nx; ++i) err = std::max(err, std::abs(sv.velocity()[d](i, j, k) + m.velocity[d]));
  EXPECT_LT(err, 1e-12 * m.velocity.norm());
  EXPECT_TRUE(sv.options().sponge.active());
  // run.json states the layer.
  CfdRunOptions ro;
  ro.bodies = false;
  ro.directory = fresh_dir("sponge");
  (void)run_cfd(c, c.kinematics, m, ro);  // one wingbeat of 60 steps: run.json is written at the end
  const auto j = nlohmann::json::parse(read_text(ro.directory + "/run.json"));
  EXPECT_NEAR(j["grid"]["sponge_width_m"].get<double>(), plan.sponge_width, 1e-15);
  EXPECT_NEAR(j["grid"]["sponge_rate_per_s"].get<double>(), plan.sponge_rate, 1e-9);

  const Case wide = cfd_case("wide_sponge.toml", testing::replace(keys, "sponge_R = 0.3", "sponge_R = 0.55"));
  const std::string too_wide =
      testing::expect_input_error([&] { (void)plan_cfd(wide, wide.kinematics, m); }, "aero.cfd.sponge_R");
  EXPECT_NE(too_wide.find("more than the 0.5 between the fine box"), std::string::npos) << too_wide;
  testing::expect_input_error(
      [&] { (void)cfd_case("sponge_rate.toml", testing::replace(keys, "sponge_rate = 10", "sponge_rate = 0")); },
      "aero.cfd.sponge_rate");
  // A layer on some faces only is checked against their room alone: 0.55 R fits below (0.6) but not at the others.
  const Case below = cfd_case("sponge_below.toml", testing::replace(keys, "sponge_R = 0.3",
                                                                     "sponge_R = 0.55\nsponge_faces = [\"below\"]"));
  const CfdPlan below_plan = plan_cfd(below, below.kinematics, m);
  for (int f = 0; f < 6; ++f) EXPECT_EQ(below_plan.sponge_faces[std::size_t(f)], f == face(2, 1)) << f;
  testing::expect_input_error(
      [&] { (void)cfd_case("sponge_faces.toml", testing::replace(keys, "sponge_R = 0.3",
                                                                 "sponge_R = 0.3\nsponge_faces = [\"bottom\"]")); },
      "aero.cfd.sponge_faces");
  // Force partitioning takes the layer's force into its outer part (tests/cfd/test_fpm.cpp), so the two go together.
  const Case fpm = load_case(testing::write_temp(
      "sponge_fpm.toml", testing::replace(cfd_case_text(std::string(keys) + "\n[aero.cfd.fpm]\n"),
                                          "model = \"quasi-steady\"", "model = \"cfd\"")));
  EXPECT_TRUE(fpm.aero.cfd.fpm.enabled);
  EXPECT_DOUBLE_EQ(fpm.aero.cfd.sponge_R, 0.3);
}

// The loads agree with those the driver gave before it became a Simulation (forces.csv of this case written by
// the earlier build, tests/data/cfd): the only change is that the parts' accelerations are analytic instead of
// central differences over 0.05 of a stage, an O(eps^2) difference. Tolerance 1e-7 of the largest force
// (measured 1.5e-9); a changed load or sign would show at the loads' own size. The earlier build had no bound on
// the band values where two parts meet (ImmersedOptions::contact), so it is off here; with it the
// loads of this tiny moth differ by up to 0.25 % of the largest force (the wing roots against the body).
// The reference was written again when the level-set lattices were centred on each part's box (a symmetric body
// then has a symmetric level set) and faces on the mirror plane between the wings' bands took both wings' values:
// together these change the loads of these impulsive first steps by up to 4.4 % of the largest force. Written again
// when the test moth's CFD wing took a narrow base (valid_cfd_case_text: its elliptic wings cut through each other);
// the file guards the loads against unintended change.
TEST(CfdSimulation, LoadsMatchTheDriverBeforeTheSplit) {
  const Case c = cfd_case("moth_restart.toml", tiny_moth_keys);
  SimulationOptions unbounded;
  unbounded.contact = ImmersedOptions::Contact::quadratic;
  Simulation sim(c, c.kinematics, BodyMotion{}, plan_cfd(c, c.kinematics, BodyMotion{}), unbounded);
  const std::string file = std::string(FLAPSTAB_SOURCE_DIR) + "/tests/data/cfd/tiny_moth_forces_before_split.csv";
  // FLAPSTAB_REWRITE_REFERENCE=1 writes the reference again from this build (after an intended change of the loads;
  // say why in the file's second line and in the commit), and the test is skipped.
  if (std::getenv("FLAPSTAB_REWRITE_REFERENCE")) {
    std::ofstream out(file);
    out << "# flapstab cfd: loads of the fluid on each part at the first 10 steps of the tiny moth "
           "(tests/cfd/test_ns_run.cpp, contact = quadratic)\n"
        << "# rewritten when the test moth's CFD wing became the narrow-based planform (its elliptic wings cut through "
           "each other, which plan_cfd now refuses; 2026-12-04)\n"
        << forces_csv_header(sim.plan().parts) << "\n";
    for (int k = 0; k < 10; ++k) out << forces_csv_row(sim.advance().row) << "\n";
    GTEST_SKIP() << "reference written to " << file;
  }
  std::ifstream in(file);
  ASSERT_TRUE(in.good());
  std::vector<CfdLoadRow> ref;
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#' && line.rfind("time_s", 0) != 0) ref.push_back(parse_forces_csv_row(line));
  ASSERT_EQ(ref.size(), 10u);
  double scale = 0;
  for (const auto& r : ref) scale = std::max(scale, r.total().force.norm());
  for (const auto& r : ref) {
    const CfdLoadRow now = sim.advance().row;
    EXPECT_EQ(now.step, r.step);
    EXPECT_NEAR(now.time, r.time, 1e-15);
    EXPECT_LT((now.total().force - r.total().force).norm(), 1e-7 * scale) << r.step;
    EXPECT_LT((now.total().moment - r.total().moment).norm(), 1e-7 * scale * c.insect.wing.length) << r.step;
  }
}

}  // namespace
}  // namespace flapstab::ns
