// Force partitioning (cfd/fpm): the influence potentials against closed forms, the added mass they give, and the
// partition of computed flows (closure, impulsive start).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <fmt/format.h>

#include "cfd/fpm/partition.hpp"
#include "common/oscillating_sphere.hpp"
#include "common/sphere_flow.hpp"
#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/navier_stokes/operators.hpp"
#include "cfd/navier_stokes/solver.hpp"

namespace flapstab {
namespace {

using namespace flapstab::ns;
using fpm::ForcePartition;
constexpr double pi = 3.14159265358979323846;

// Level sets of spheres: part 0 inside radius R1 about the origin; with R2 > 0, part 1 outside radius R2 (a fixed
// spherical container).
fpm::LevelFunction spheres(double R1, double R2 = 0) {
  return [=](int part, const Vec3& x, double) { return part == 0 ? x.norm() - R1 : R2 - x.norm(); };
}

Grid sphere_grid(double h, double lo, double hi, double box) {
  const StretchedAxis ax{lo, hi, -box, box, h, 1.1, 8};
  return Grid(Axis::stretched(ax, false), Axis::stretched(ax, false), Axis::stretched(ax, false));
}

struct PotentialError {
  double max_error = 0, rms_error = 0;  // relative to max |phi| = R/2, over fluid cells with R + 2h < r < 2R
  double added_mass = 0;                // m_xx (rho = 1)
  int iterations = 0;
  std::size_t cells = 0;
};

// A sphere of radius R = 0.5 in the box [-4, 4]^3 (fine spacing h over [-0.8, 0.8]^3, stretched by 1.1 outside).
PotentialError sphere_potential(double h) {
  const double R = 0.5;
  const Grid g = sphere_grid(h, -4, 4, 0.8);
  ForcePartition f(g, {.components = {0}});
  const auto level = spheres(R);
  const auto& rep = f.update(level, 1, fpm::owners_of(g, 1, level));
  PotentialError e;
  e.iterations = rep[0].stats.iterations;
  EXPECT_TRUE(rep[0].stats.converged);
  EXPECT_LT(rep[0].imbalance, 1e-12);
  e.cells = g.cells();
  const Field& phi = f.potential(0, 0);
  const Shape s = g.shape();
  double sum = 0;
  int n = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const double x = g.axis[0].xc[i], y = g.axis[1].xc[j], z = g.axis[2].xc[k], r = std::sqrt(x * x + y * y + z * z);
        if (r < R + 2 * h || r > 2 * R) continue;
        const double exact = -R * R * R * x / (2 * r * r * r);
        const double err = std::abs(phi(i, j, k) - exact) / (R / 2);
        e.max_error = std::max(e.max_error, err);
        sum += err * err;
        ++n;
      }
  e.rms_error = std::sqrt(sum / n);
  e.added_mass = f.added_mass(0, 0, 1.0)(0, 0);
  return e;
}

// The influence potential of a sphere for F_x is the potential of the sphere translating at unit speed,
// phi = -(R^3 / 2 r^2) cos theta (Lamb 1932, Hydrodynamics, section 92), and its kinematic term is the added mass
// m_a = rho V / 2. The box (8 R wide, no-flux faces, phi's mean on them zero) differs from the unbounded fluid by
// about (R/L)^3 ~ 0.2-0.6 % (a sphere inside a sphere of radius 8 R: +0.59 %, see the next test's formula), which
// floors the comparison; the tolerance is 1 % on both grids (h = R/6, R/12) for the potential (rms over
// R + 2h < r < 2R, relative to R/2) and the added mass. Measured: rms 0.30 %, 0.24 %; added mass -0.24 %, -0.10 %
// (a staircase of whole cells instead of cut cells gave 3.3 %, 1.4 % and +9.5 %, +3.2 %).
TEST(FpmPotential, SphereAgainstTheTranslatingSpherePotential) {
  const double R = 0.5, V = 4.0 / 3.0 * pi * R * R * R;
  const PotentialError c = sphere_potential(R / 6), f = sphere_potential(R / 12);
  for (const auto& [name, e] : {std::pair{"R/6", c}, std::pair{"R/12", f}})
    fmt::print("h = {}: {} cells, {} iterations; phi error max {:.4f} rms {:.4f}; added mass / (rho V/2) = {:.4f}\n",
               name, e.cells, e.iterations, e.max_error, e.rms_error, e.added_mass / (V / 2));
  for (const auto& e : {c, f}) {
    EXPECT_LT(e.rms_error, 0.01);
    EXPECT_NEAR(e.added_mass / (V / 2), 1.0, 0.01);
  }
}

// A hollow sphere (a shell 0.3 < r < 0.5, one part) holds fluid cut off from the rest: that pocket is left out of
// the fluid (its Neumann problem need not be compatible on a grid), so the shell's potential and added mass are
// those of the solid sphere R = 0.5 (within the 1 % of the sphere test above). Without the pocket handling the
// inner surface's fluxes, which do not cancel exactly on the grid, made the solve diverge (hawkmoth wing roots).
// Several right-hand sides solved together (the potentials of one sample share the operator): each is the solution
// of its own problem to its own tolerance, with its own statistics. The three force potentials of a sphere and a zero
// right-hand side solved as one block against each solved alone (tolerance 1e-8 of max|b|): the block's potentials
// agree with the single solves within 1e-6 of max|phi| (both stop at a residual of 1e-8 of the data; the difference is
// what the two iteration sequences leave), the zero one converges at once with zero iterations and the sphere's
// x, y, z potentials take the same number of iterations within one (the problem is symmetric, the grid nearly so).
// Measured (h = R/6): 11 iterations each, together and alone, and the same potentials to the last bit.
TEST(FpmPotential, PotentialsSolvedTogetherMatchEachSolvedAlone) {
  const double R = 0.5, h = R / 6;
  const Grid g = sphere_grid(h, -2, 2, 0.8);
  const auto level = spheres(R);
  const fpm::FluidGeometry geo = fpm::fluid_geometry(g, 1, level, fpm::owners_of(g, 1, level));
  const fpm::NeumannLaplacian L(g, geo);
  std::vector<Field> b(4, Field(g.shape())), together(4, Field(g.shape())), alone(4, Field(g.shape()));
  for (const auto& c : geo.cuts)
    for (int d = 0; d < 3; ++d) b[std::size_t(d)][c.cell] -= c.area[d];  // -int n_d dS: the F_d datum's flux
  std::vector<Field*> xs;
  std::vector<const Field*> bs;
  for (std::size_t m = 0; m < 4; ++m) xs.push_back(&together[m]), bs.push_back(&b[m]);
  const std::vector<fpm::LaplaceStats> st = L.solve(xs, bs, 1e-8, 200);
  ASSERT_EQ(st.size(), 4u);
  for (std::size_t m = 0; m < 4; ++m) {
    const fpm::LaplaceStats one = L.solve(alone[m], b[m], 1e-8, 200);
    EXPECT_TRUE(st[m].converged) << m;
    EXPECT_TRUE(one.converged) << m;
    double diff = 0, scale = 0;
    for (std::size_t n = 0; n < g.shape().size(); ++n) {
      diff = std::max(diff, std::abs(together[m].data()[n] - alone[m].data()[n]));
      scale = std::max(scale, std::abs(alone[m].data()[n]));
    }
    if (m < 3) {
      EXPECT_GT(scale, 0.1 * R) << m;
      EXPECT_LT(diff, 1e-6 * scale) << m;
      EXPECT_LE(std::abs(st[m].iterations - one.iterations), 1) << m;
      std::printf("  potential %zu: %d iterations together, %d alone; max difference %.2e of max|phi|\n", m,
                  st[m].iterations, one.iterations, diff / scale);
    } else {
      EXPECT_EQ(st[m].iterations, 0);
      EXPECT_EQ(scale, 0.0);
    }
  }
  EXPECT_LE(std::abs(st[0].iterations - st[1].iterations), 1);
  EXPECT_LE(std::abs(st[0].iterations - st[2].iterations), 1);
}

// The faces the immersed boundary forces (FluidGeometry::forced): every face whose level set at its centre lies below
// its local width h, on a sphere R = 0.5 at h = R/6 (the grid's fine spacing), checked against the level function
// face by face near the surface; and the list of forced faces with an open share (the partition's pressure_forced
// sums over it) holds exactly the flagged faces with a nonzero aperture inside the domain.
TEST(FpmGeometry, ForcedFacesAreThoseWithinAWidthOfTheSurface) {
  const double R = 0.5, h = R / 6;
  const Grid g = sphere_grid(h, -2, 2, 0.8);
  const auto level = spheres(R);
  const fpm::FluidGeometry o = fpm::fluid_geometry(g, 1, level, fpm::owners_of(g, 1, level));
  const Shape s = g.shape();
  std::size_t flagged = 0, open = 0, checked = 0;
  for (int d = 0; d < 3; ++d)
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const int I[3] = {i, j, k};
          if (I[d] == 1) continue;  // the domain's faces
          const auto x = g.point(d, i, j, k);
          const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
          const bool flag = o.forced[std::size_t(d)][std::size_t(s(i, j, k))];
          if (r < 0.8 * R || r > R + 2 * h) {  // well inside (untested faces) or far outside: not forced
            EXPECT_FALSE(flag && r > R + 2 * h) << d << " " << i << " " << j << " " << k;
            continue;
          }
          if (r > 0.8 * R && std::abs(r - R - h) > 0.05 * h) {  // away from the threshold: the flag is exact
            EXPECT_EQ(flag, r - R < h) << d << " " << i << " " << j << " " << k << " r " << r;
            ++checked;
          }
          flagged += flag;
          open += flag && o.aperture[std::size_t(d)](i, j, k) > 0;
        }
  EXPECT_GT(checked, 1000u);
  EXPECT_EQ(o.forced_open.size(), open);
  for (const auto& f : o.forced_open) {
    EXPECT_TRUE(o.forced[std::size_t(f.d)][std::size_t(s(f.I[0], f.I[1], f.I[2]))]);
    EXPECT_GT(o.aperture[std::size_t(f.d)](f.I[0], f.I[1], f.I[2]), 0.0);
  }
  EXPECT_GT(flagged, open);  // the solid faces inside the surface are forced and closed
}

// With the forced region as the potentials' body (FpmBody::forced_region) the same sphere's forced faces are all
// closed, every face the surface body leaves open outside them stays open, the parts' surface pieces close (their
// areas sum to zero: the Neumann data balance) and the body is the surface body widened by about h: its volume lies
// between the spheres of radius R + h/2 and R + 3h/2 (the forced faces reach h beyond R; cells count as the body's when
// every face is closed, so the staircase sits between).
TEST(FpmGeometry, ForcedRegionBodyClosesEveryForcedFace) {
  const double R = 0.5, h = R / 6;
  const Grid g = sphere_grid(h, -2, 2, 0.8);
  const auto level = spheres(R);
  const auto owners = fpm::owners_of(g, 1, level);
  const fpm::FluidGeometry o = fpm::fluid_geometry(g, 1, level, owners);
  const fpm::FluidGeometry w = fpm::fluid_geometry(g, 1, level, owners, 4, fpm::FpmBody::forced_region);
  const Shape s = g.shape();
  EXPECT_TRUE(w.forced_open.empty());
  std::size_t closed = 0;
  for (int d = 0; d < 3; ++d)
    for (std::size_t n = 0; n < s.size(); ++n) {
      EXPECT_EQ(w.forced[std::size_t(d)][n], o.forced[std::size_t(d)][n]);
      if (w.forced[std::size_t(d)][n]) {
        EXPECT_EQ(w.aperture[std::size_t(d)][std::ptrdiff_t(n)], 0.0);
        ++closed;
      } else {
        EXPECT_EQ(w.aperture[std::size_t(d)][std::ptrdiff_t(n)], o.aperture[std::size_t(d)][std::ptrdiff_t(n)]);
      }
    }
  EXPECT_GT(closed, 1000u);
  Vec3 area = Vec3::Zero(), scale = Vec3::Zero();
  for (const auto& c : w.cuts) area += c.area, scale += c.area.cwiseAbs();
  EXPECT_LT(area.norm(), 1e-12 * scale.norm());
  double solid = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) solid += (1 - w.volume_fraction(i, j, k)) * g.volume(i, j, k);
  const auto ball = [](double r) { return 4.0 / 3.0 * pi * r * r * r; };
  fmt::print("forced-region body: volume {:.5f} = that of a sphere of radius R + {:.3f} h\n", solid,
             (std::cbrt(solid / (4.0 / 3.0 * pi)) - R) / h);
  EXPECT_GT(solid, ball(R + 0.5 * h));
  EXPECT_LT(solid, ball(R + 1.5 * h));
}

TEST(FpmPotential, FluidCutOffInsideAShellIsLeftOut) {
  const double R = 0.5, V = 4.0 / 3.0 * pi * R * R * R, h = R / 6;
  const Grid g = sphere_grid(h, -4, 4, 0.8);
  const fpm::LevelFunction shell = [](int, const Vec3& x, double) { return std::max(x.norm() - 0.5, 0.3 - x.norm()); };
  ForcePartition f(g, {.components = {0}});
  const auto& rep = f.update(shell, 1, fpm::owners_of(g, 1, shell));
  EXPECT_TRUE(rep[0].stats.converged);
  std::size_t inner = 0;  // cells whose centre lies well inside the cavity
  const Shape s = g.shape();
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const Vec3 x(g.axis[0].xc[i], g.axis[1].xc[j], g.axis[2].xc[k]);
        if (x.norm() < 0.3 - h) {
          ++inner;
          EXPECT_EQ(f.geometry().volume_fraction(i, j, k), 0.0);
        }
      }
  EXPECT_GT(inner, 0u);
  EXPECT_GE(rep[0].pocket_cells, inner);
  for (const auto& c : f.geometry().cuts) EXPECT_GT(f.geometry().volume_fraction[c.cell], 0.0);
  const double ma = f.added_mass(0, 0, 1.0)(0, 0);
  fmt::print("shell 0.3 < r < 0.5, h = R/6: {} pocket cells, added mass / (rho V/2) = {:.4f}\n", rep[0].pocket_cells,
             ma / (V / 2));
  EXPECT_NEAR(ma / (V / 2), 1.0, 0.01);
}

// Pockets across a periodic axis: a tube (0.4 < r < 0.6) along the periodic z axis from the bottom face up to a cap
// at 0.3 < z < 0.5. Its inside reaches the walls only through the periodic image of the bottom face (fluid above
// the tube), so it must stay; with a second cap at -0.5 < z < -0.3 the fluid between the caps is a pocket.
TEST(FpmPotential, PocketsFollowPeriodicImages) {
  const Grid g(Axis::uniform(-1, 1, 32, false), Axis::uniform(-1, 1, 32, false), Axis::uniform(-1, 1, 32, true));
  const auto tube = [](const Vec3& x, bool closed) {
    const double r = std::hypot(x.x(), x.y());
    double v = std::max({r - 0.6, 0.4 - r, x.z() - 0.5});                   // the tube wall
    v = std::min(v, std::max({r - 0.6, 0.3 - x.z(), x.z() - 0.5}));          // the top cap
    if (closed) v = std::min(v, std::max({r - 0.6, -0.5 - x.z(), x.z() + 0.3}));  // a bottom cap
    return v;
  };
  const Shape s = g.shape();
  for (const bool closed : {false, true}) {
    const fpm::LevelFunction level = [&](int, const Vec3& x, double) { return tube(x, closed); };
    const fpm::FluidGeometry geo = fpm::fluid_geometry(g, 1, level, fpm::owners_of(g, 1, level));
    std::size_t inside = 0, active = 0;  // cells well inside the tube between the caps
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const Vec3 x(g.axis[0].xc[i], g.axis[1].xc[j], g.axis[2].xc[k]);
          if (std::hypot(x.x(), x.y()) < 0.3 && std::abs(x.z()) < 0.2) {
            ++inside;
            active += geo.volume_fraction(i, j, k) > 0;
          }
        }
    fmt::print("tube along the periodic axis, {}: {} cells inside, {} active, {} pocket cells\n",
               closed ? "closed by a second cap" : "open through the periodic face", inside, active, geo.pocket_cells);
    ASSERT_GT(inside, 0u);
    if (closed) {
      EXPECT_EQ(active, 0u);
      EXPECT_GE(geo.pocket_cells, inside);
    } else {
      EXPECT_EQ(active, inside);
      EXPECT_EQ(geo.pocket_cells, 0u);
    }
  }
}

// A sphere R1 inside a fixed concentric sphere R2 (both no-flux): m_a = (2/3) rho pi R1^3 [1 + 2 (R1/R2)^3] /
// [1 - (R1/R2)^3] (Lamb 1932, section 92; Zhang 2015 thesis uses it for the confined FPM check). R1/R2 = 1/2:
// 1.4286 x rho V / 2. The container enters as part 1 (fixed, no-flux). No box effect here: the error is the
// discretisation's. Tolerance 2 % at h = R1/6 and 0.5 % at R1/12 (measured -1.00 %, +0.04 %; a staircase of whole
// cells gave +10.2 % and +5.9 %).
TEST(FpmPotential, SphereInsideAFixedSphere) {
  const double R1 = 0.5, R2 = 1.0, V = 4.0 / 3.0 * pi * R1 * R1 * R1, q = std::pow(R1 / R2, 3);
  const double exact = 0.5 * V * (1 + 2 * q) / (1 - q);
  double err[2];
  int n = 0;
  for (double h : {R1 / 6, R1 / 12}) {
    const Grid g = sphere_grid(h, -1.2, 1.2, 1.1);
    ForcePartition f(g, {.components = {0}});
    const auto level = spheres(R1, R2);
    const auto& rep = f.update(level, 2, fpm::owners_of(g, 2, level));
    EXPECT_TRUE(rep[0].stats.converged);
    const double m = f.added_mass(0, 0, 1.0)(0, 0);
    err[n++] = m / exact - 1;
    fmt::print("h = R1/{:.0f}: {} cells, {} iterations; added mass {:.5f}, exact {:.5f} ({:+.2f} %)\n", R1 / h,
               g.cells(), rep[0].stats.iterations, m, exact, 100 * (m / exact - 1));
  }
  EXPECT_LT(std::abs(err[0]), 0.02);
  EXPECT_LT(std::abs(err[1]), 0.005);
}

void print(const char* what, const fpm::PartPartition& P, int k, double scale) {
  fmt::print("{}: kinematic {:+.5f} (centripetal {:+.5f}), vortex {:+.5f}, viscous {:+.5f}, outer {:+.5f}; sum {:+.5f}; "
             "direct pressure {:+.5f}\n",
             what, P.kinematic[k] / scale, P.centripetal[k] / scale, P.vortex[k] / scale, P.viscous[k] / scale,
             P.outer[k] / scale, P.sum()[k] / scale, P.pressure[k] / scale);
}

struct Accelerated {
  fpm::PartPartition P;
  double surface = 0, exchange = 0;  // the immersed boundary's pressure force (surface integral, momentum exchange)
};

// A sphere (R = 0.5, rho = 1) accelerated from rest at a = 1 along x in fluid at rest (walled box [-4, 4]^3, fine
// spacing h over [-0.8, 0.8]^3, nu = 1e-4), partitioned at t = 0.01 (5 steps).
Accelerated accelerated_sphere(double h) {
  const double R = 0.5, a = 1.0;
  const Grid g = sphere_grid(h, -4, 4, 0.8);
  SolverOptions opt;
  opt.nu = 1e-4;
  opt.dt = 0.002;
  Solver s(g, Boundaries::all(BC::velocity), opt);
  s.initialise([](double, double, double) { return Vec3::Zero(); });
  ImmersedBoundary ib(g);
  ib.add_part(sphere_mesh(R, 24), [=](double t) {
    const Vec3 c(0.5 * a * t * t, 0, 0);
    PartState st{RigidTransform{Mat3::Identity(), c}, RigidVelocity{c, Vec3(a * t, 0, 0), Vec3::Zero()}};
    st.acceleration = Vec3(a, 0, 0);
    return st;
  });
  ib.attach(s);
  for (int n = 0; n < 5; ++n) s.step();
  const std::vector<PartState> states{ib.state(0, s.time())};
  ForcePartition f(g, {.components = {0, 1, 2}});
  f.update(ib, states);
  Accelerated r;
  r.P = f.partition(s, states, 1.0)[0];
  r.surface = ib.loads(s, Vec3::Zero())[0].pressure_force.x();
  r.exchange = ib.exchange_loads(s, Vec3::Zero())[0].pressure_force.x();
  return r;
}

// At the first instants the flow round a sphere accelerated from rest is the potential flow of the accelerating
// sphere: velocities ~ a t, so Q ~ t^2 and the vortex-induced part vanishes, the viscous part grows like the
// Basset force 12 R^2 sqrt(pi rho mu) a sqrt(t) (Landau & Lifshitz, Fluid Mechanics, section 24: 1.4 % of
// rho V a / 2 at t = 0.01), and the pressure force is the added-mass force -rho V a / 2 (the 8 R box adds about
// 0.5 %). Asserted on h = R/8 and R/16: the kinematic part within 2 % of -rho V a / 2 (measured -0.44 %, +0.08 %);
// vortex-induced + viscous below 5 % of it (measured < 0.01 %); no centripetal part (pure translation).
// Closure: the partition's sum against the pressure force computed directly from the solver's pressure on the same
// cut cells. The direct force reads 29 % and 16 % too high on the two grids, and the immersed boundary's own surface
// integral 23 % and 14 % (its momentum exchange 100 % and 52 %): the solver's pressure next to an accelerating body
// carries the first-order error of the direct forcing (the fictitious fluid inside accelerates with the body and the
// one pressure field is continuous across the smeared interface). The partition's kinematic term is a surface
// integral of the body's acceleration, which the solver's pressure does not enter, so the closure gap is the
// direct force's error: asserted to fall at least 1.6-fold from R/8 to R/16 (first order: 2).
TEST(FpmPartition, ImpulsivelyAcceleratedSphereIsAllKinematic) {
  const double R = 0.5, a = 1.0, V = 4.0 / 3.0 * pi * R * R * R, ref = -0.5 * V * a;
  double gap[2], free_gap[2];
  int n = 0;
  for (double h : {R / 8, R / 16}) {
    const Accelerated r = accelerated_sphere(h);
    const fpm::PartPartition& P = r.P;
    print(fmt::format("accelerated sphere, h = R/{:.0f}, F_x / (rho V a / 2)", R / h).c_str(), P, 0, -ref);
    fmt::print("  immersed boundary pressure force / (rho V a / 2): surface {:+.5f}, momentum exchange {:+.5f}; "
               "direct pressure off the forced faces {:+.5f}\n",
               r.surface / -ref, r.exchange / -ref, (P.pressure[0] - P.pressure_forced[0]) / -ref);
    EXPECT_NEAR(P.kinematic[0] / ref, 1.0, 0.02);
    EXPECT_LT(std::abs(P.vortex[0] + P.viscous[0]), 0.05 * std::abs(P.kinematic[0]));
    EXPECT_LT(std::abs(P.centripetal[0]), 1e-12);
    gap[n] = std::abs(P.sum()[0] / P.pressure[0] - 1);
    free_gap[n++] = std::abs(P.sum()[0] / (P.pressure[0] - P.pressure_forced[0]) - 1);
  }
  EXPECT_GT(gap[0] / gap[1], 1.6);
  // The direct force's excess is on the faces the immersed boundary forces: off them it is 0.933 and 0.985 of
  // rho V a / 2 (R/8, R/16), and the parts' sum is within 6.7 % and 1.7 % of it. Asserted: below 3 % on R/16 and
  // falling at least 2-fold.
  EXPECT_LT(free_gap[1], 0.03);
  EXPECT_GT(free_gap[0] / free_gap[1], 2.0);
}

// u_x at the origin, interpolated trilinearly from the staggered field.
double ux_at_origin(const Grid& g, const Field& u) {
  auto below = [](const std::vector<double>& x, int n) {
    int i = 1;
    while (i < n && x[std::size_t(i + 1)] <= 0) ++i;
    return i;
  };
  const Shape s = g.shape();
  const int i = below(g.axis[0].xf, s.nx), j = below(g.axis[1].xc, s.ny), k = below(g.axis[2].xc, s.nz);
  const double wx = -g.axis[0].xf[std::size_t(i)] / (g.axis[0].xf[std::size_t(i + 1)] - g.axis[0].xf[std::size_t(i)]);
  const double wy = -g.axis[1].xc[std::size_t(j)] / (g.axis[1].xc[std::size_t(j + 1)] - g.axis[1].xc[std::size_t(j)]);
  const double wz = -g.axis[2].xc[std::size_t(k)] / (g.axis[2].xc[std::size_t(k + 1)] - g.axis[2].xc[std::size_t(k)]);
  double v = 0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int c = 0; c < 2; ++c)
        v += (a ? wx : 1 - wx) * (b ? wy : 1 - wy) * (c ? wz : 1 - wz) * u(i + a, j + b, k + c);
  return v;
}

struct SpongeDriven {
  fpm::PartPartition P;
  fpm::PartPartition W;  // the same with the forced region as the body
  double reference = 0;  // 3/2 rho V a, a the acceleration at the origin without the sphere
  double surface = 0;    // the immersed boundary's pressure force (surface integral)
};

// A sphere (R = 0.5, rho = 1) held at rest in a walled box [-4, 4]^3 of fluid at rest, set in motion by a sponge
// layer 2 deep along the y+ face relaxing towards u_far = (1, 0, 0) at rate 5 (nothing else drives the flow);
// partitioned at t = 0.01 (5 steps, nu = 1e-4). The same run without the sphere gives the acceleration at the origin.
SpongeDriven sponge_driven_sphere(double h) {
  const double R = 0.5, V = 4.0 / 3.0 * pi * R * R * R;
  const Grid g = sphere_grid(h, -4, 4, 0.8);
  SolverOptions opt;
  opt.nu = 1e-4;
  opt.dt = 0.002;
  opt.sponge.width[std::size_t(face(1, 1))] = 2.0;
  opt.sponge.rate = 5.0;
  opt.sponge.velocity = Vec3(1, 0, 0);
  opt.keep_stage_velocities = true;
  SpongeDriven r;
  {
    Solver free(g, Boundaries::all(BC::velocity), opt);
    free.initialise([](double, double, double) { return Vec3::Zero(); });
    for (int n = 0; n < 4; ++n) free.step();
    const double before = ux_at_origin(g, free.velocity()[0]);
    free.step();
    r.reference = 1.5 * V * (ux_at_origin(g, free.velocity()[0]) - before) / opt.dt;
  }
  Solver s(g, Boundaries::all(BC::velocity), opt);
  s.initialise([](double, double, double) { return Vec3::Zero(); });
  ImmersedBoundary ib(g);
  ib.add_part(sphere_mesh(R, 24), [](double) {
    return PartState{RigidTransform{Mat3::Identity(), Vec3::Zero()},
                     RigidVelocity{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()}};
  });
  ib.attach(s);
  for (int n = 0; n < 5; ++n) s.step();
  const std::vector<PartState> states{ib.state(0, s.time())};
  ForcePartition f(g, {.components = {0, 1, 2}});
  f.update(ib, states);
  r.P = f.partition(s, states, 1.0)[0];
  ForcePartition w(g, {.components = {0}, .body = fpm::FpmBody::forced_region});
  w.update(ib, states);
  r.W = w.partition(s, states, 1.0)[0];
  r.surface = ib.loads(s, Vec3::Zero())[0].pressure_force.x();
  return r;
}

// The sponge layer's force enters the partition through its outer part, rho int f . grad phi dV with
// f = -sigma (u - u_far). Here it is the only thing driving the flow: a layer along the y+ face pushes its fluid
// towards +x, and since the box is closed the rest of the fluid returns along -x, accelerated by a pressure that
// is harmonic outside the layer (div f = 0). At the first instants that flow is irrotational round the sphere, so
// the force on the held sphere is the Froude-Krylov force plus the added mass, 3/2 rho V a, with a the ambient
// acceleration at its centre (Auton, Hunt & Prud'homme 1988, J Fluid Mech 197:241; the Froude-Krylov part exactly,
// since a harmonic field's mean over the sphere is its centre value, the added mass up to the ambient field's
// variation over the sphere, small here): the reference, a taken from the same run without the sphere. The
// kinematic part vanishes (the sphere is held), the vortex-induced and viscous parts are second order in t and
// small, so the outer part carries the force. Without the layer's term the partition would give about zero; with
// the wrong sign, -1. Tolerance 1 %, the box's images ((R/L)^3, as for the potential above); measured -0.34 %,
// -0.35 % on h = R/6, R/10. The pressure
// force computed directly from the solver's pressure reads 15.6 % and 10.8 % high (the immersed boundary's surface
// integral 14.0 %, 10.2 %): the first-order error of the direct forcing next to the held body, as for the
// accelerated sphere above; asserted to fall from one grid to the next (first order would be 1.67-fold; 1.44).
TEST(FpmPartition, SpongeLayerForceIsInTheOuterPart) {
  double gap[2];
  int n = 0;
  for (double h : {0.5 / 6, 0.5 / 10}) {
    const SpongeDriven r = sponge_driven_sphere(h);
    const fpm::PartPartition& P = r.P;
    const std::string what =
        fmt::format("sponge-driven flow past a held sphere, h = R/{:.0f}, F_x / (3/2 rho V a)", 0.5 / h);
    print(what.c_str(), P, 0, r.reference);
    fmt::print("  3/2 rho V a = {:+.5e}; immersed boundary surface pressure force / it {:+.5f}\n", r.reference,
               r.surface / r.reference);
    EXPECT_LT(r.reference, 0);  // the return flow runs along -x
    EXPECT_NEAR(P.outer[0] / r.reference, 1.0, 0.01);
    EXPECT_LT(std::abs(P.kinematic[0]), 1e-12 * std::abs(r.reference));
    EXPECT_LT(std::abs(P.vortex[0] + P.viscous[0]), 0.05 * std::abs(r.reference));
    gap[n++] = std::abs(P.pressure[0] / r.reference - 1);
    // With the forced region as the body the parts close to the potentials' tolerance, the layer's force taken on the
    // last stage's predicted velocity u + alpha dt grad(phi_3), which the layer relaxes: measured 3.5e-9 and 5.0e-9
    // (h = R/6, R/10); with the velocity at the step's end instead, as the cut-cell body takes it, 8.4e-7 and 8.3e-7.
    // Asserted within 1e-7.
    const fpm::PartPartition& W = r.W;
    fmt::print("  forced region as the body: outer {:+.5f}, sum {:+.5f}, pressure {:+.5f}; gap {:.2e}\n",
               W.outer[0] / r.reference, W.sum()[0] / r.reference, W.pressure[0] / r.reference,
               std::abs(W.sum()[0] / W.pressure[0] - 1));
    EXPECT_NEAR(W.sum()[0], W.pressure[0], 1e-7 * std::abs(W.pressure[0]));
  }
  EXPECT_GT(gap[0] / gap[1], 1.2);
}

// The solver's own momentum terms over the open faces the immersed boundary does not force, in the form of the last
// step's last Runge-Kutta stage (ns::Solver::stage_velocity; the test flows keep the stages), weighted with the
// potential of component 0 like the direct pressure force's Green identity: sum A_f beta_f (phi_c - phi_nb) times
// -c_d (c the predictor's convective acceleration, of u_2 and u_1 with the stage's weights gamma / alpha and
// zeta / alpha) and times -(u_d - u_2,d) / (alpha dt). With the viscous and outer parts they give the direct pressure
// force off the forced faces (the stage's momentum equation holds exactly on those faces).
struct OpenFaceMomentum {
  double convective = 0, unsteady = 0;
};
struct LastStage {
  const VectorField &u, &u1, &u2;
  double wg, wz, adt;
  explicit LastStage(const Solver& solver)
      : u(solver.velocity()), u1(solver.stage_velocity(0)), u2(solver.stage_velocity(1)),
        wg(Solver::stage_coefficients(2).gamma / Solver::stage_coefficients(2).alpha()),
        wz(Solver::stage_coefficients(2).zeta / Solver::stage_coefficients(2).alpha()),
        adt(Solver::stage_coefficients(2).alpha() * solver.last_dt()) {}
};
OpenFaceMomentum open_face_momentum(const Solver& solver, const ForcePartition& fp) {
  const Grid& g = solver.grid();
  const Shape s = g.shape();
  const fpm::FluidGeometry& o = fp.geometry();
  const Field& phi = fp.potential(0, 0);
  const LastStage L(solver);
  OpenFaceMomentum M;
  for (int d = 0; d < 3; ++d) {
    const int e = (d + 1) % 3, hh = (d + 2) % 3;
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const int I[3] = {i, j, k};
          const double beta = o.aperture[std::size_t(d)](i, j, k);
          if (I[d] == 1 || beta <= 0 || o.forced[std::size_t(d)][std::size_t(s(i, j, k))]) continue;
          int B[3] = {i, j, k};
          --B[d];
          const double area =
              g.axis[std::size_t(e)].dc[std::size_t(I[e])] * g.axis[std::size_t(hh)].dc[std::size_t(I[hh])];
          const double w = beta * area * (phi(i, j, k) - phi(B[0], B[1], B[2]));
          M.convective -= w * (L.wg * convective_acceleration(g, L.u2, d, i, j, k) +
                               L.wz * convective_acceleration(g, L.u1, d, i, j, k));
          M.unsteady -= w * (L.u[d](i, j, k) - L.u2[d](i, j, k)) / L.adt;
        }
  }
  return M;
}

// The identity of the forced-region body's parts (below): kinematic + vortex-induced + outer = the solver's convective
// and unsteady terms over the open faces, to round-off (asserted within 1e-10 of the largest term). The kinematic part
// holds the cells' divergence of du/dt weighted with phi (the projections' tolerance over the last stage; printed,
// with the difference it would leave without it).
void expect_parts_sum_by_parts(const Solver& solver, const ForcePartition& f, const fpm::PartPartition& P,
                               const char* what) {
  const OpenFaceMomentum M = open_face_momentum(solver, f);
  const Grid& g = solver.grid();
  const Shape s = g.shape();
  const LastStage L(solver);
  Field div_now(s), div_before(s);
  divergence(g, L.u, div_now, 1.0);
  divergence(g, L.u2, div_before, 1.0);
  const Field& phi = f.potential(0, 0);
  double residual = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i)
        if (f.geometry().active(s(i, j, k)))
          residual += phi(i, j, k) * g.volume(i, j, k) * (div_now(i, j, k) - div_before(i, j, k)) / L.adt;
  const double parts = P.kinematic[0] + P.vortex[0] + P.outer[0], terms = M.convective + M.unsteady;
  const double scale = std::max({std::abs(P.kinematic[0]), std::abs(P.vortex[0]), std::abs(M.convective),
                                 std::abs(M.unsteady)});
  fmt::print("{}, t = {:.4f}, forced region as the body: kinematic {:+.6e} vortex {:+.6e} outer {:+.6e}; solver's "
             "convective {:+.6e} unsteady {:+.6e}; the kinematic part's divergence term {:+.3e}; difference / largest "
             "term {:.2e}, without the divergence term {:.2e}\n",
             what, solver.time(), P.kinematic[0], P.vortex[0], P.outer[0], M.convective, M.unsteady, residual,
             std::abs(parts - terms) / scale, std::abs(parts - residual - terms) / scale);
  EXPECT_NEAR(parts, terms, 1e-10 * scale) << what;
}

// One more step of the steady sphere's flow, partitioned with the cut-cell body (a) and the widened one (b): both
// keep the boundary velocities before the step (d u / dt over it), then solve their potentials and partition.
std::pair<fpm::PartPartition, fpm::PartPartition> step_and_partition(testing::SphereInStream& flow, ForcePartition& a,
                                                                     ForcePartition& b) {
  a.record_boundary(flow.solver);
  b.record_boundary(flow.solver);
  flow.solver.step();
  const std::vector<PartState> states{flow.ib.state(0, flow.solver.time())};
  a.update(flow.ib, states);
  b.update(flow.ib, states);
  return {a.partition(flow.solver, states, 1.0)[0], b.partition(flow.solver, states, 1.0)[0]};
}

// Closure on a steady flow: the sphere at Re = 100 (the immersed boundary's drag validation case,
// tests/common/sphere_flow.hpp) at t = 8 D/U, past its start-up, on h = D/8 and D/12. The sphere does not move, so
// the kinematic part vanishes and the pressure drag is the vortex-induced + viscous + outer parts; their sum is
// compared with the pressure force computed directly on the same cut cells (its discretisation error is the
// closure gap) and with the immersed boundary's own pressure drag (surface integral, momentum exchange).
TEST(FpmPartition, SteadySphereAtRe100Closes) {
  const double q = 0.5 * pi / 4;  // rho U^2 / 2 x frontal area, rho = U = D = 1
  double gap[2], region_gap[2], region_drag[2];
  int n = 0;
  for (double h : {1.0 / 8, 1.0 / 12}) {
    testing::SphereInStream flow(h, 1.1, 12);
    while (flow.solver.time() + flow.solver.stable_dt() < 8) flow.solver.step();
    ForcePartition f(flow.grid, {.components = {0, 1, 2}});
    ForcePartition fr(flow.grid, {.components = {0, 1, 2}, .body = fpm::FpmBody::forced_region});
    const auto [P, R] = step_and_partition(flow, f, fr);
    expect_parts_sum_by_parts(flow.solver, fr, R, fmt::format("steady sphere Re 100, D/{:.0f}", 1 / h).c_str());
    print("  the same with the forced region as the body", R, 0, q);
    EXPECT_EQ(R.pressure_forced[0], 0.0);  // no forced face is open
    region_gap[n] = std::abs(R.sum()[0] / R.pressure[0] - 1);
    region_drag[n] = R.pressure[0] / q;
    print(fmt::format("steady sphere Re 100, h = D/{:.0f}, C_D parts (t = {:.2f})", 1 / h, flow.solver.time()).c_str(),
          P, 0, q);
    const double surface = flow.ib.loads(flow.solver, Vec3::Zero())[0].pressure_force.x() / q,
                 exchange = flow.ib.exchange_loads(flow.solver, Vec3::Zero())[0].pressure_force.x() / q;
    fmt::print("  immersed boundary pressure C_D: surface {:.4f}, momentum exchange {:.4f}\n", surface, exchange);
    EXPECT_GT(P.vortex[0] + P.viscous[0] + P.outer[0], 0.0);  // a drag
    // against the pressure off the forced faces: measured -1.4 % and +1.1 % (D/8, D/12)
    const double free = P.pressure[0] - P.pressure_forced[0];
    fmt::print("  pressure on the forced faces {:.4f}; sum / (direct - it) - 1 = {:+.4f}\n", P.pressure_forced[0] / q,
               P.sum()[0] / free - 1);
    EXPECT_GT(P.pressure_forced[0], 0.0);
    EXPECT_NEAR(P.sum()[0] / free, 1.0, 0.03);
    gap[n++] = std::abs(P.sum()[0] / P.pressure[0] - 1);
  }
  fmt::print("  closure gap |sum / direct - 1|: {:.4f} (D/8), {:.4f} (D/12)\n", gap[0], gap[1]);
  // Measured: the parts sum to 0.331 / 0.391 of the direct 0.405 / 0.441 (gap 18.2 % / 11.4 %: 1.6-fold for a
  // 1.5-fold finer grid, first order). What remains is the pressure on the faces the immersed boundary forces, where
  // direct forcing replaces the momentum equation (0.068 / 0.055 of C_D, DISABLED_SteadySphereClosureStudy below).
  // Before the viscous term left those faces out (2026-12-07) their MAC Laplacian, which spans the kink between the
  // band's profile and the rigid velocity inside the sphere, took -0.055 / -0.068 off the sum: gaps 32 % / 27 %, and
  // at Re 20 a gap of 31 % on every grid. Asserted: below 15 % on D/12 and falling at least 1.3-fold.
  EXPECT_LT(gap[1], 0.15);
  EXPECT_GT(gap[0] / gap[1], 1.3);
  // The forced region as the potentials' body (FpmBody::forced_region: every forced face closed, so the momentum
  // equation holds on every open face and no pressure is left on forced faces; the kinematic term takes the fluid's
  // acceleration on that body's faces, where the fluid slides along, and every term is the solver's own in the form of
  // its last Runge-Kutta stage, which balances the pressure at the step's end exactly on those faces): measured
  // pressure C_D on that body 0.703 / 0.629, closure gap 3.0e-10 / 5.8e-10 (the potentials' tolerance, 1e-8 of their
  // data). Asserted within 1e-7. Earlier forms: with the terms over the whole step (the velocity at its end and its
  // change over it) the gap was 0.17 % / 0.15 %; without the kinematic part's divergence term (the projections'
  // tolerance over the last stage) 0.29 % / 1.4 %; with Q from central differences at the cell centres and the
  // faces' u . grad u in advective form 1.6 % / 6.5 % (14 % on D/16); with the parts' rigid acceleration (zero here)
  // instead of the fluid's, 16 % / 24 %.
  fmt::print("  forced region as the body: pressure C_D {:.4f} (D/8), {:.4f} (D/12); closure gap {:.2e}, {:.2e}\n",
             region_drag[0], region_drag[1], region_gap[0], region_gap[1]);
  EXPECT_LT(region_gap[0], 1e-7);
  EXPECT_LT(region_gap[1], 1e-7);
}

// ns::convective_acceleration is the predictor's convective term at one face: on a stretched x axis, a periodic y axis
// and a uniform z axis with a smooth velocity field (ghosts included), it equals -N of predict() with nu = 0 at every
// face the predictor sweeps, to round-off (the predictor's kernel may contract multiply-adds: 1e-12 of the largest
// value). The widened body's partition and the identity test below build on it; a stencil or index slip shows here.
TEST(NavierStokesOperators, ConvectiveAccelerationIsThePredictorsConvectiveTerm) {
  const Grid g(Axis::stretched(StretchedAxis{-1, 1, -0.3, 0.3, 0.1, 1.08, 1}, false), Axis::uniform(0, 1, 6, true),
               Axis::uniform(-0.5, 0.5, 5, false));
  const Shape s = g.shape();
  VectorField u(s), N(s), ustar(s);
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k <= s.nz + 1; ++k)
      for (int j = 0; j <= s.ny + 1; ++j)
        for (int i = 0; i <= s.nx + 1; ++i)
          u[d](i, j, k) = std::sin(1.3 * i + 0.7 * d) * std::cos(0.9 * j - 0.4 * k) + 0.2 * (d + 1) * k;
  const Field p(s);
  predict(g, u, p, N, ustar, 0.0, 1.0, StageCoefficients{});
  double largest = 0, worst = 0;
  for (int d = 0; d < 3; ++d)
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          largest = std::max(largest, std::abs(N[d](i, j, k)));
          worst = std::max(worst, std::abs(convective_acceleration(g, u, d, i, j, k) + N[d](i, j, k)));
        }
  EXPECT_GT(largest, 1.0);
  EXPECT_LT(worst, 1e-12 * largest);
}

// With the forced region as the body the kinematic and vortex-induced terms are built from the solver's own convective
// acceleration c (ns::convective_acceleration) and the velocity's rate, both in the form of the last Runge-Kutta stage,
// so that, summed by parts, they equal the solver's convective and unsteady momentum terms of that stage on the open
// faces: kinematic + vortex-induced + outer = -rho sum_open A_f (du_d/dt + c_d)(phi_c - phi_nb)
// (docs/theory/force-partitioning.md, "The forced region as the body"). What can break it: a face left out or counted
// twice, a sign, the domain's faces (the outer term's u . grad u in the cells' net outflow), a cell's six faces not
// all counted, the kinematic part's divergence term. Checked here on the oscillating sphere at 3/8 of its first period
// (moving, decelerating, faces entering and leaving the forcing band; the unsteady terms), h = D/8, and in
// SteadySphereAtRe100Closes on the steady sphere (the convective terms). Measured: 4.9e-15 of the largest term
// (steady sphere 1.9e-14, 3.8e-14); without the divergence term 3.7e-6 (4.3e-3, 2.0e-2).
TEST(FpmPartition, ForcedRegionPartsSumByPartsToTheSolversMomentumTerms) {
  using Osc = testing::OscillatingSphere;
  Osc flow(1.0 / 8, true, 12);
  ForcePartition f(flow.grid, {.components = {0}, .body = fpm::FpmBody::forced_region});
  for (int k = 1; k < 3 * flow.per_period / 8; ++k) flow.solver.step();
  f.record_boundary(flow.solver);
  flow.solver.step();
  const std::vector<PartState> states{Osc::state(flow.solver.time())};
  f.update(flow.ib, states);
  const fpm::PartPartition P = f.partition(flow.solver, states, 1.0)[0];
  expect_parts_sum_by_parts(flow.solver, f, P, "oscillating sphere, D/8");
}

// The steady sphere's closure on a series of grids and two Reynolds numbers (a study, not run in CI; results in
// docs/validation.md, "Force partitioning"):
//   FLAPSTAB_FPM_RE=100 FLAPSTAB_FPM_GRIDS="8,12,16" ./build/tests/test_cfd --gtest_also_run_disabled_tests
//     --gtest_filter='FpmPartition.DISABLED_SteadySphereClosureStudy'
// Grids finer than D/16 solve the pressure with hypre (the multigrid's point smoother stalls on the stretched cells).
// The direct pressure force equals sum over open faces of a_f (p_c - p_nb)(phi_c - phi_nb) exactly (the discrete
// Green identity, docs/theory/force-partitioning.md). Printed beside the parts: that sum over the faces the immersed
// boundary forces (where the momentum equation does not hold) and over the rest, and the viscous term the forced
// faces would add if they were not left out (the MAC Laplacian there, as over the other open faces). The line
// "WIDENED" gives the same flow's partition with the forced region as the body (FpmBody::forced_region), "MOMENTUM"
// the solver's own momentum terms summed over the open faces the forcing leaves alone, for either body.
TEST(FpmPartition, DISABLED_SteadySphereClosureStudy) {
  const double q = 0.5 * pi / 4;
  const double re = std::getenv("FLAPSTAB_FPM_RE") ? std::atof(std::getenv("FLAPSTAB_FPM_RE")) : 100.0;
  std::vector<int> grids;
  {
    std::string list = std::getenv("FLAPSTAB_FPM_GRIDS") ? std::getenv("FLAPSTAB_FPM_GRIDS") : "8,12,16";
    for (std::size_t a = 0; a < list.size();) {
      const std::size_t b = std::min(list.find(',', a), list.size());
      grids.push_back(std::stoi(list.substr(a, b - a)));
      a = b + 1;
    }
  }
  for (int m : grids) {
    const auto t0 = std::chrono::steady_clock::now();
    testing::SphereInStream flow(1.0 / m, 1.1, std::max(12, 2 * m), m > 16, re);
    while (flow.solver.time() + flow.solver.stable_dt() < 8) flow.solver.step();
    ForcePartition f(flow.grid, {.components = {0}});
    ForcePartition fw(flow.grid, {.components = {0}, .body = fpm::FpmBody::forced_region});
    const auto [P, W] = step_and_partition(flow, f, fw);
    for (int which = 0; which < 2; ++which) {  // the solver's own momentum terms, for either body
      const fpm::PartPartition& X = which ? W : P;
      const OpenFaceMomentum M = open_face_momentum(flow.solver, which ? fw : f);
      fmt::print("MOMENTUM {} D/{}: solver's convective {:+.4f} unsteady {:+.4f} viscous {:+.4f} outer {:+.4f}, sum "
                 "{:+.4f}; direct off the forced faces {:+.4f}; partition kinematic + vortex {:+.4f} ({:+.4f}, "
                 "{:+.4f})\n",
                 which ? "widened" : "surface", m, M.convective / q, M.unsteady / q, X.viscous[0] / q, X.outer[0] / q,
                 (M.convective + M.unsteady + X.viscous[0] + X.outer[0]) / q, (X.pressure[0] - X.pressure_forced[0]) / q,
                 (X.kinematic[0] + X.vortex[0]) / q, X.kinematic[0] / q, X.vortex[0] / q);
    }
    fmt::print("WIDENED D/{}: direct {:.4f} sum {:.4f} gap {:+.2e}; kinematic {:+.4f} vortex {:+.4f} viscous {:+.4f}\n",
               m, W.pressure[0] / q, W.sum()[0] / q, W.sum()[0] / W.pressure[0] - 1, W.kinematic[0] / q,
               W.vortex[0] / q, W.viscous[0] / q);
    const Grid& g = flow.grid;
    const Shape s = g.shape();
    const fpm::FluidGeometry& o = f.geometry();
    const Field& p = flow.solver.pressure();
    const Field& phi = f.potential(0, 0);
    const double nu = flow.solver.options().nu;
    double green_forced = 0, green_free = 0, viscous_forced = 0;
    for (int d = 0; d < 3; ++d) {
      const Axis& ad = g.axis[std::size_t(d)];
      const int e = (d + 1) % 3, hh = (d + 2) % 3;
      const Field& ud = flow.solver.velocity()[d];
      for (int k = 1; k <= s.nz; ++k)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) {
            const int I[3] = {i, j, k};
            const double beta = o.aperture[std::size_t(d)](i, j, k);
            if (I[d] == 1 || beta <= 0) continue;
            int B[3] = {i, j, k};
            --B[d];
            const double area =
                g.axis[std::size_t(e)].dc[std::size_t(I[e])] * g.axis[std::size_t(hh)].dc[std::size_t(I[hh])];
            const double dphi = phi(i, j, k) - phi(B[0], B[1], B[2]);
            const double green = beta * area * ad.idf[std::size_t(I[d])] * (p(i, j, k) - p(B[0], B[1], B[2])) * dphi;
            if (!o.forced[std::size_t(d)][std::size_t(s(i, j, k))]) {
              green_free += green;
              continue;
            }
            green_forced += green;
            viscous_forced += nu * fpm::face_laplacian(g, ud, d, i, j, k) * beta * area * dphi;
          }
    }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    fmt::print("Re {:g}, D/{}: {} cells, t = {:.2f}, {:.0f} s\n", re, m, g.cells(), flow.solver.time(), secs);
    fmt::print("  C_D parts: vortex {:.4f}, viscous {:.4f}, outer {:.4f}; sum {:.4f}; direct {:.4f}; gap {:.1f} %\n",
               P.vortex[0] / q, P.viscous[0] / q, P.outer[0] / q, P.sum()[0] / q, P.pressure[0] / q,
               100 * (1 - P.sum()[0] / P.pressure[0]));
    fmt::print("  direct over the forced faces {:.4f}, over the rest {:.4f}; viscous term of the forced faces "
               "(left out) {:.4f}\n",
               green_forced / q, green_free / q, viscous_forced / q);
    // the identity holds up to the potential's tolerance, and the library's pressure_forced is its forced share
    EXPECT_NEAR(green_forced + green_free, P.pressure[0], 1e-6 * std::abs(P.pressure[0]));
    EXPECT_NEAR(green_forced, P.pressure_forced[0], 1e-12 * std::abs(P.pressure[0]));
  }
}

// Closure on an unsteady flow: the sphere oscillating in fluid at rest (the immersed boundary's Stokes-force case,
// tests/common/oscillating_sphere.hpp: R/delta = 2, Re 0.8), partitioned at 8 phases of its third period on h = D/8
// and D/12. The kinematic part is the added-mass force -(rho V / 2) a of the sphere (the box of 8 R adds ~0.6 %).
// Its worst error over the phases, relative to the force's amplitude, was measured at 3.9 % (D/8) and 1.6 % (D/12):
// the cut cells change as the sphere crosses 0.4 cells, more on the coarser grid (the static sphere's added mass at
// D/12 is -0.24 %). Asserted: below 2 % on D/12 and falling with the grid. Closure: the rms over the phases of
// (sum - direct cut-cell pressure force), relative to the direct force's peak, measured 24.2 % and 16.9 % (the
// viscous part dominates at Re 0.8; what remains is the pressure on the forced faces, which carries direct forcing's
// first-order error next to an accelerating body, as in the impulsive start above); 28 % and 24 % before the viscous
// term left the forced faces out. Asserted: below 20 % on D/12 and falling at least 1.25-fold.
TEST(FpmPartition, OscillatingSphereAddedMassAndClosure) {
  using Osc = testing::OscillatingSphere;
  const double V = 4.0 / 3.0 * pi * Osc::R * Osc::R * Osc::R, am = 0.5 * V, amp = am * Osc::u0 * Osc::omega;
  double gap[2], kin[2], free_gap[2], region_gap[2];
  int n = 0;
  for (double h : {1.0 / 8, 1.0 / 12}) {
    Osc flow(h, true, 12);
    ForcePartition f(flow.grid, {.components = {0}});
    ForcePartition fr(flow.grid, {.components = {0}, .body = fpm::FpmBody::forced_region});
    const int N = flow.per_period, sample_every = N / 8;
    double sum2 = 0, free2 = 0, peak = 0, worst_kin = 0, region2 = 0, region_peak = 0;
    for (int k = 1; k <= 3 * N; ++k) {
      if (k > 2 * N && k % sample_every == 0) f.record_boundary(flow.solver), fr.record_boundary(flow.solver);
      flow.solver.step();
      if (k <= 2 * N || k % sample_every != 0) continue;
      const std::vector<PartState> states{Osc::state(flow.solver.time())};
      f.update(flow.ib, states);
      fr.update(flow.ib, states);
      const fpm::PartPartition P = f.partition(flow.solver, states, 1.0)[0];
      const fpm::PartPartition R = fr.partition(flow.solver, states, 1.0)[0];
      region2 += std::pow(R.sum()[0] - R.pressure[0], 2);
      region_peak = std::max(region_peak, std::abs(R.pressure[0]));
      fmt::print("  forced region as the body: kinematic {:+.5f}, vortex {:+.5f}, viscous {:+.5f}, outer {:+.5f}; "
                 "sum {:+.5f}, direct {:+.5f}\n",
                 R.kinematic[0] / amp, R.vortex[0] / amp, R.viscous[0] / amp, R.outer[0] / amp, R.sum()[0] / amp,
                 R.pressure[0] / amp);
      const double a = states[0].acceleration.x();
      worst_kin = std::max(worst_kin, std::abs(P.kinematic[0] + am * a) / amp);
      sum2 += std::pow(P.sum()[0] - P.pressure[0], 2);
      free2 += std::pow(P.sum()[0] - P.pressure[0] + P.pressure_forced[0], 2);
      peak = std::max(peak, std::abs(P.pressure[0]));
      fmt::print("  h = D/{:.0f}, t/T = {:.3f}: kinematic {:+.5f} (added mass {:+.5f}), vortex {:+.5f}, viscous {:+.5f}, "
                 "outer {:+.5f}; sum {:+.5f}, direct {:+.5f}\n",
                 1 / h, flow.solver.time(), P.kinematic[0] / amp, -am * a / amp, P.vortex[0] / amp, P.viscous[0] / amp,
                 P.outer[0] / amp, P.sum()[0] / amp, P.pressure[0] / amp);
    }
    kin[n] = worst_kin;
    region_gap[n] = std::sqrt(region2 / 8) / region_peak;
    fmt::print("  forced region as the body: closure rms {:.2e} of its direct force's peak\n", region_gap[n]);
    free_gap[n] = std::sqrt(free2 / 8) / peak;
    gap[n++] = std::sqrt(sum2 / 8) / peak;
    fmt::print("oscillating sphere, h = D/{:.0f}: kinematic within {:.4f} of the added-mass force's amplitude; closure "
               "rms {:.4f} of the direct force's peak, {:.4f} against the direct force off the forced faces\n",
               1 / h, worst_kin, gap[n - 1], std::sqrt(free2 / 8) / peak);
  }
  EXPECT_LT(kin[1], 0.02);
  EXPECT_LT(kin[1], kin[0]);
  EXPECT_LT(gap[1], 0.2);
  EXPECT_GT(gap[0] / gap[1], 1.25);
  // Against the direct force off the forced faces (the pressure there carries the forcing's error): rms 5.2 % and
  // 3.0 % of the peak. Asserted: below 4 % on D/12 and falling.
  EXPECT_LT(free_gap[1], 0.04);
  EXPECT_LT(free_gap[1], free_gap[0]);
  // With the forced region as the potentials' body (every forced face closed: nothing left on forced faces; the
  // kinematic term from the fluid's acceleration on its faces; every term in the form of the solver's last
  // Runge-Kutta stage) each sample closes to the potentials' tolerance: rms measured 9.1e-11 and 1.4e-11 of that
  // body's peak pressure force. Asserted within 1e-7 on both grids. With the terms over the whole step it was 1.5 %
  // and 0.64 % (9.3 % and 4.7 % with the parts' rigid acceleration instead).
  EXPECT_LT(region_gap[0], 1e-7);
  EXPECT_LT(region_gap[1], 1e-7);
}

}  // namespace
}  // namespace flapstab
