// Immersed rigid parts (cfd/navier_stokes/immersed.hpp): level sets, direct forcing, loads.
//
// Unit checks: the lattice level set against the exact mesh distance; a body moving with a uniform flow leaves it
// uniform; Galilean invariance (moving sphere in fluid at rest = fixed sphere in the opposite flow); a membrane
// spanning a periodic duct blocks the flow; a sphere at rest in fluid at rest (with a pressure offset) carries
// no force.
// Validation (docs/validation.md, "Immersed boundary"):
//  - sphere, Re = 100, steady: C_D = 1.09 (Johnson & Patel 1999, J Fluid Mech 378:19, 1.08-1.09 across their
//    grids; Mittal et al. 2008, J Comput Phys 227:4825, 1.08-1.09; reference 1.09);
//  - sphere oscillating with small amplitude in fluid at rest: Stokes' oscillating-sphere force (Landau &
//    Lifshitz, Fluid Mechanics, 2nd ed., section 24, problem 5), amplitude, phase and smoothness (fresh cells);
//    the same case as a fixed sphere in an oscillating far field gives the same force once the Froude-Krylov
//    term rho V dU/dt is removed;
//  - membrane disk broadside to a uniform flow at Re = 20 (zero thickness): symmetric, drag against the disk
//    correlation of Clift, Grace & Weber 1978 (Bubbles, Drops and Particles, Table 6.9:
//    C_D = 64/(pi Re) (1 + 10^x), x = -0.883 + 0.906 log10 Re - 0.025 log10^2 Re, 1.5 < Re < 133).
#include <gtest/gtest.h>
#include <Eigen/Dense>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <stdexcept>
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/navier_stokes/mesh_query.hpp"
#include "common/oscillating_sphere.hpp"
#include "common/sphere_flow.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::Mat3;
using flapstab::pi;
using flapstab::Vec3;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// A part translating with constant velocity v from position x0 at t = 0.
PartMotion translating(const Vec3& x0, const Vec3& v) {
  return [x0, v](double t) {
    const Vec3 c = x0 + v * t;
    return PartState{RigidTransform{Mat3::Identity(), c}, RigidVelocity{c, v, Vec3::Zero()}};
  };
}

// Membrane disk of radius a in the plane x = 0 (normal +x), rings x sectors triangles.
TriangleMesh disk_mesh(double a, int rings, int sectors) {
  TriangleMesh m;
  m.label = "disk";
  m.membrane = true;
  m.vertices.push_back(Vec3::Zero());
  for (int r = 1; r <= rings; ++r)
    for (int s = 0; s < sectors; ++s) {
      const double rho = a * r / rings, th = 2 * pi * s / sectors;
      m.vertices.push_back(Vec3(0, rho * std::cos(th), rho * std::sin(th)));
    }
  auto v = [&](int r, int s) { return r == 0 ? 0 : 1 + (r - 1) * sectors + (s % sectors); };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < sectors; ++s) {
      // normal (b - a) x (c - a) along +x: counter-clockwise in (y, z)
      if (r == 0) {
        m.triangles.push_back({v(0, 0), v(1, s), v(1, s + 1)});
      } else {
        m.triangles.push_back({v(r, s), v(r + 1, s), v(r + 1, s + 1)});
        m.triangles.push_back({v(r, s), v(r + 1, s + 1), v(r, s + 1)});
      }
    }
  return m;
}

// Membrane square [-L/2, L/2]^2 in the plane x = 0 (normal +x), n x n squares, two triangles each.
TriangleMesh plate_mesh(double L, int n) {
  TriangleMesh m;
  m.label = "plate";
  m.membrane = true;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.push_back(Vec3(0, L * (double(i) / n - 0.5), L * (double(j) / n - 0.5)));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      m.triangles.push_back({a, b, d});
      m.triangles.push_back({a, d, c});
    }
  return m;
}

// ---------------------------------------------------------------------------------------------------------------
// Unit checks

// The lattice level set (trilinear on a lattice of spacing hl = h/2) against MeshQuery's exact distance to the
// same mesh, at random points within 3 cells of the surface, for a moved and rotated part. Trilinear
// interpolation of a distance field of curvature 1/R errs by at most 3 hl^2 / (8 R) (plus float storage,
// 1e-7 relative); tolerance hl^2 / R.
TEST(ImmersedLevelSet, MatchesMeshDistance) {
  const double R = 0.5, h = 2.0 / 32, hl = h / 2;
  const Grid g(Axis::uniform(-1, 1, 32, false), Axis::uniform(-1, 1, 32, false), Axis::uniform(-1, 1, 32, false));
  const Mat3 rot = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const RigidTransform pose{rot, Vec3(0.1, -0.05, 0.02)};
  const TriangleMesh sphere = sphere_mesh(R, 12);
  TriangleMesh plate = plate_mesh(0.8, 8);
  ImmersedBoundary ib(g);
  ib.add_part(sphere, fixed_part(pose));
  ib.add_part(plate, fixed_part(pose));
  const MeshQuery qs(sphere, pose), qp(plate, pose);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-0.8, 0.8);
  double es = 0, ep = 0;
  int ns = 0, np = 0;
  while (ns < 2000 || np < 2000) {
    const Vec3 x(U(rng), U(rng), U(rng));
    const double ds = qs.signed_distance(x), dp = qp.closest(x).distance;
    if (std::abs(ds) < 3 * h && ns < 2000) es = std::max(es, std::abs(ib.level_set(0, 0.0, x) - ds)), ++ns;
    if (dp < 3 * h && np < 2000) ep = std::max(ep, std::abs(ib.level_set(1, 0.0, x) - dp)), ++np;
  }
  std::printf("  level set vs mesh distance: sphere max error %.2e, plate %.2e (hl^2/R = %.2e)\n", es, ep, hl * hl / R);
  EXPECT_LT(es, hl * hl / R);
  // The plate's distance is piecewise linear except near its edges (cylindrical there, radius >= the distance).
  EXPECT_LT(ep, hl * hl / (0.5 * h));
  EXPECT_LT(ib.bytes(), std::size_t(8) << 20);
}

// Clear errors: an open surface loaded as closed, and a lattice that would exceed 64 M points.
TEST(ImmersedLevelSet, RejectsOpenClosedMeshesAndHugeLattices) {
  const Grid g(Axis::uniform(-1, 1, 8, false), Axis::uniform(-1, 1, 8, false), Axis::uniform(-1, 1, 8, false));
  ImmersedBoundary ib(g);
  TriangleMesh open = plate_mesh(0.5, 4);
  open.membrane = false;
  EXPECT_THROW(ib.add_part(open, fixed_part()), std::invalid_argument);
  std::vector<double> faces{-1.0};
  for (int i = 1; i <= 8; ++i) faces.push_back(-1.0 + 1e-4 * i);  // one cell of 1e-4 m sets the lattice spacing
  faces.push_back(1.0);
  const Grid fine(Axis(faces, false), Axis::uniform(-1, 1, 8, false), Axis::uniform(-1, 1, 8, false));
  ImmersedBoundary big(fine);
  EXPECT_THROW(big.add_part(sphere_mesh(0.5, 6), fixed_part()), std::invalid_argument);
  EXPECT_EQ(big.parts(), 0u);
}

// A sphere translating with the velocity of a uniform flow in a periodic box: the forcing imposes exactly the
// flow's value, so the flow stays uniform to round-off (tolerance 1e-12 U).
TEST(ImmersedForcing, BodyMovingWithUniformFlowLeavesItUniform) {
  const Vec3 U(1.0, 0.5, -0.25);
  const Grid g(Axis::uniform(0, 2, 24, true), Axis::uniform(0, 2, 24, true), Axis::uniform(0, 2, 24, true));
  SolverOptions opt;
  opt.nu = 0.01;
  Solver s(g, Boundaries::all(BC::periodic), opt);
  s.initialise([&](double, double, double) { return U; });
  ImmersedBoundary ib(g);
  ib.add_part(sphere_mesh(0.4, 10), translating(Vec3(0.8, 1, 1), U));
  ib.attach(s);
  for (int n = 0; n < 10; ++n) s.step();
  double err = 0;
  for (int d = 0; d < 3; ++d)
    for (int k = 1; k <= 24; ++k)
      for (int j = 1; j <= 24; ++j)
        for (int i = 1; i <= 24; ++i) err = std::max(err, std::abs(s.velocity()[d](i, j, k) - U[d]));
  std::printf("  uniform flow with a co-moving sphere: max |u - U| = %.1e after 10 steps (%zu solid, %zu band faces)\n", err,
              ib.solid_faces(), ib.band_faces());
  EXPECT_LT(err, 1e-12);
  EXPECT_GT(ib.solid_faces(), 0u);
  EXPECT_GT(ib.band_faces(), 0u);
}

// A sphere straddling the lower x boundary of a periodic box, moving through fluid at rest: the faces on the seam
// (face 1 and its image n+1) must be forced alike, or cell n sees an unforced face (divergence O(u/h), 21 here
// before the fix, 1.6e-3 with it). Tolerances: no jump across the seam (1e-12), divergence < 1e-2 u/h.
TEST(ImmersedForcing, BodyOnAPeriodicSeamKeepsImagesConsistent) {
  const Grid g(Axis::uniform(0, 2, 24, true), Axis::uniform(0, 2, 24, true), Axis::uniform(0, 2, 24, true));
  SolverOptions opt;
  opt.nu = 0.01;
  opt.dt = 0.01;
  Solver s(g, Boundaries::all(BC::periodic), opt);
  s.initialise([&](double, double, double) { return Vec3::Zero(); });
  ImmersedBoundary ib(g);
  ib.add_part(sphere_mesh(0.4, 10), translating(Vec3(0.02, 1, 1), Vec3(0.5, 0.2, 0)));
  ib.attach(s);
  s.step();
  double jump = 0, umax = 0;
  for (int k = 1; k <= 24; ++k)
    for (int j = 1; j <= 24; ++j) {
      jump = std::max(jump, std::abs(s.velocity()[0](1, j, k) - s.velocity()[0](25, j, k)));
      umax = std::max(umax, std::abs(s.velocity()[0](1, j, k)));
    }
  std::printf("  sphere on a periodic seam: velocity jump across the seam %.1e, max divergence %.1e (u up to %.2f)\n", jump,
              s.max_divergence(), umax);
  EXPECT_GT(umax, 0.1);
  EXPECT_LT(jump, 1e-12);
  // Projection leaves 1e-3 of the predictor's divergence (Poisson rtol); an unforced image face would leave O(u/h).
  EXPECT_LT(s.max_divergence(), 1e-2 * umax / (2.0 / 24));
}

// A closed sphere at rest in fluid at rest, with a constant pressure offset: no force, moment or power (the
// offset cancels on a closed surface). Tolerance 1e-12 of the offset times the area.
TEST(ImmersedLoads, SphereAtRestCarriesNoForce) {
  const Grid g(Axis::uniform(-1, 1, 16, false), Axis::uniform(-1, 1, 16, false), Axis::uniform(-1, 1, 16, false));
  SolverOptions opt;
  opt.nu = 0.1;
  opt.dt = 0.01;
  Solver s(g, Boundaries::all(BC::velocity), opt);
  s.initialise([](double, double, double) { return Vec3::Zero(); }, 0, [](double, double, double) { return 5.0; });
  ImmersedBoundary ib(g);
  ib.add_part(sphere_mesh(0.4, 8), fixed_part(RigidTransform{Mat3::Identity(), Vec3(0.05, 0, -0.03)}));
  ib.attach(s);
  for (int n = 0; n < 3; ++n) s.step();
  const PartLoads L = ib.loads(s, Vec3::Zero())[0];
  const double scale = 5.0 * 4 * pi * 0.16;
  std::printf("  sphere at rest: |F| = %.1e, |M| = %.1e, power %.1e (offset x area = %.2f)\n", L.force().norm(), L.moment().norm(),
              L.power, scale);
  EXPECT_LT(L.force().norm(), 1e-12 * scale);
  EXPECT_LT(L.moment().norm(), 1e-12 * scale);
  EXPECT_EQ(L.power, 0.0);
  // cell flags: the centre cell is solid, some are ghost (band)
  int solid = 0, ghost = 0;
  for (CellFlag f : s.flags()) solid += f == CellFlag::solid, ghost += f == CellFlag::ghost;
  EXPECT_GT(solid, 0);
  EXPECT_GT(ghost, 0);
}

// Galilean invariance: a sphere moving with velocity V through fluid at rest in a periodic box, and a fixed
// sphere in the same box with the fluid moving at -V, are the same flow in frames moving relative to each other.
// Compared: the mean drag over t in [0.5, 1] D/V at Re = VD/nu = 20 (the moving sphere crosses 8 cells; the
// difference is the discretisation's dependence on where the body lies relative to the grid). Tolerance 3 %.
TEST(ImmersedForcing, MovingSphereEqualsFixedSphereInOppositeFlow) {
  const double D = 1, V = 1, nu = V * D / 20;
  const Grid g(Axis::uniform(-2, 2, 32, true), Axis::uniform(-2, 2, 32, true), Axis::uniform(-2, 2, 32, true));
  SolverOptions opt;
  opt.nu = nu;
  opt.dt = 0.02;
  double drag[2], drag_ex[2];
  for (int c = 0; c < 2; ++c) {
    const bool moving = c == 0;
    Solver s(g, Boundaries::all(BC::periodic), opt);
    s.initialise([&](double, double, double) { return moving ? Vec3::Zero() : Vec3(-V, 0, 0); });
    ImmersedBoundary ib(g);
    ib.add_part(sphere_mesh(D / 2, 12), moving ? translating(Vec3(-0.5, 0, 0), Vec3(V, 0, 0)) : fixed_part());
    ib.attach(s);
    double sum = 0, sum_ex = 0;
    int n = 0;
    while (s.time() < 1 - 1e-9) {
      s.step();
      if (s.time() > 0.5 + 1e-9) {
        sum -= ib.loads(s, Vec3::Zero())[0].force().x();
        sum_ex -= ib.exchange_loads(s, Vec3::Zero())[0].force().x();
        ++n;
      }
    }
    drag[c] = sum / n;
    drag_ex[c] = sum_ex / n;
  }
  std::printf("  Galilean: mean drag, moving sphere %.4f, fixed sphere in opposite flow %.4f (ratio %.4f); momentum exchange "
              "%.4f, %.4f (ratio %.4f)\n",
              drag[0], drag[1], drag[0] / drag[1], drag_ex[0], drag_ex[1], drag_ex[0] / drag_ex[1]);
  EXPECT_NEAR(drag[0] / drag[1], 1.0, 0.03);
  EXPECT_NEAR(drag_ex[0] / drag_ex[1], 1.0, 0.03);
}

// A membrane plate spanning the whole cross-section of a periodic duct (larger than the duct, so it crosses the
// y and z seams) stops an initially uniform flow: the flux through the duct must decay to zero. Tolerance:
// 1e-2 of the initial flux after t = 0.5 L/U.
TEST(ImmersedForcing, MembraneBlocksADuct) {
  const Grid g(Axis::uniform(0, 2, 32, true), Axis::uniform(0, 1, 16, true), Axis::uniform(0, 1, 16, true));
  SolverOptions opt;
  opt.nu = 0.05;
  opt.dt = 0.01;
  Solver s(g, Boundaries::all(BC::periodic), opt);
  s.initialise([](double, double, double) { return Vec3(1, 0, 0); });
  ImmersedBoundary ib(g);
  ib.add_part(plate_mesh(1.4, 14), fixed_part(RigidTransform{Mat3::Identity(), Vec3(1.0, 0.5, 0.5)}));
  ib.attach(s);
  auto flux = [&](int i) {
    double q = 0;
    for (int k = 1; k <= 16; ++k)
      for (int j = 1; j <= 16; ++j) q += s.velocity()[0](i, j, k) / 256;
    return q;
  };
  while (s.time() < 0.25 - 1e-9) s.step();
  const double q1 = flux(8);
  while (s.time() < 0.5 - 1e-9) s.step();
  const double q = flux(8);
  std::printf("  membrane across a periodic duct: flux %.2e of the initial after t = 0.25, %.2e after t = 0.5 (%zu solid faces)\n", q1,
              q, ib.solid_faces());
  EXPECT_LT(std::abs(q), 1e-2);
  EXPECT_LT(std::abs(q), std::abs(q1));
}

// Two parts close together (ImmersedOptions::contact): two membrane plates (wider than the periodic box) 4.2 cell widths apart (3 cell widths
// between their effective surfaces, each 0.6 widths off its mid-plane), one sliding in its plane at V, the other
// still, in a fully periodic box. In the gap the steady flow is plane Couette flow, linear between the two effective
// surfaces (exact for the Navier-Stokes equations: no pressure gradient, no advection). There the probes of each
// plate's band faces reach the other plate's band, so the gap treatment sets those faces from the two surface
// velocities; the steady profile must then be the Couette line to the solver's round-off (tolerance 1e-4 V). The
// quadratic through the surface and two probes reads the other plate's forced faces, whose values are off that
// line (the still plate's solid faces hold 0 where the line continues below 0): its profile is printed beside.
double couette_gap_error(ImmersedOptions::Contact contact) {
  const int n = 64;
  const double h = 1.0 / n, V = 1.0;
  const Grid g(Axis::uniform(0, 8 * h, 8, true), Axis::uniform(0, 1, n, true), Axis::uniform(0, 8 * h, 8, true));
  SolverOptions opt;
  opt.nu = 0.01;
  opt.dt = 0.002;
  Solver s(g, Boundaries::all(BC::periodic), opt);
  s.initialise([](double, double, double) { return Vec3::Zero(); });
  ImmersedOptions io;
  io.contact = contact;
  ImmersedBoundary ib(g, io);
  Mat3 R;  // the plate's normal +x onto +y
  R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const double ya = 0.4 + 0.3 * h, yb = ya + 4.2 * h;  // mid-planes, off the cell centres and faces
  // An unbounded plane sliding in itself looks the same at every instant: the pose stays, the velocity is V.
  ib.add_part(plate_mesh(1.0, 4), [=](double) {
    const Vec3 c(4 * h, ya, 4 * h);
    return PartState{RigidTransform{R, c}, RigidVelocity{c, Vec3(V, 0, 0), Vec3::Zero()}};
  });
  ib.add_part(plate_mesh(1.0, 4), fixed_part(RigidTransform{R, Vec3(4 * h, yb, 4 * h)}));
  ib.attach(s);
  while (s.time() < 1.5 - 1e-9) s.step();
  const double lo = ya + io.membrane_half_thickness * h, hi = yb - io.membrane_half_thickness * h;
  double err = 0;
  for (int j = 1; j <= n; ++j) {
    const double y = g.axis[1].xc[std::size_t(j)];
    if (!(y > lo && y < hi)) continue;
    const double exact = V * (hi - y) / (hi - lo);
    for (int k = 1; k <= 8; ++k)
      for (int i = 1; i <= 8; ++i) err = std::max(err, std::abs(s.velocity()[0](i, j, k) - exact));
  }
  return err / V;
}

TEST(ImmersedContact, GapBetweenTwoPartsTakesTheCouetteProfile) {
  const double gap = couette_gap_error(ImmersedOptions::Contact::gap);
  const double bounded = couette_gap_error(ImmersedOptions::Contact::bounded);
  const double quadratic = couette_gap_error(ImmersedOptions::Contact::quadratic);
  std::printf("  plane Couette flow in a gap of 3 cell widths: largest error %.2e V (gap treatment), %.2e V (bounded "
              "quadratic), %.2e V (quadratic)\n", gap, bounded, quadratic);
  EXPECT_LT(gap, 1e-4);
}

// ---------------------------------------------------------------------------------------------------------------
// Sphere at Re = 100, steady

struct SphereResult {
  double cd, cd_pressure, cl, cd_forcing;
  int nx, ny, nz, steps;
  double seconds, poisson_iterations;
};

// D = 1, U = 1, nu = 1/100 (tests/common/sphere_flow.hpp: domain, fine box of spacing h, stretching, inflow and
// outflow). Impulsive start from the uniform flow; C_D averaged over the last 2 D/U before t_end.
SphereResult run_sphere(double h, double ratio, double t_end, int mesh_n) {
  const auto t0 = std::chrono::steady_clock::now();
  const double D = 1, U = 1;
  flapstab::testing::SphereInStream flow(h, ratio, mesh_n);
  const Grid& g = flow.grid;
  Solver& s = flow.solver;
  ImmersedBoundary& ib = flow.ib;
  SphereResult r{};
  const Shape sh = g.shape();
  r.nx = sh.nx, r.ny = sh.ny, r.nz = sh.nz;
  const double q = 0.5 * U * U * pi * D * D / 4;
  double sum = 0, sump = 0, suml = 0, sumf = 0, iters = 0;
  int n = 0;
  while (s.time() < t_end) {
    s.step();
    ++r.steps;
    for (const auto& st : s.poisson_stats()) iters += st.cycles;
    if (s.time() > t_end - 2) {
      const PartLoads L = ib.loads(s, Vec3::Zero())[0];
      sum += L.force().x() / q, sump += L.pressure_force.x() / q, suml += std::hypot(L.force().y(), L.force().z()) / q;
      sumf += ib.exchange_loads(s, Vec3::Zero())[0].force().x() / q;
      ++n;
    }
  }
  r.cd = sum / n, r.cd_pressure = sump / n, r.cl = suml / n, r.cd_forcing = sumf / n;
  r.poisson_iterations = iters / r.steps;
  r.seconds = seconds_since(t0);
  return r;
}

void print(const SphereResult& r) {
  std::printf("  sphere Re 100 (%d x %d x %d, %d steps, %.1f Poisson its/step, %.1f s): momentum exchange C_D = %.4f (error %+.1f %%); "
              "surface integral C_D = %.4f (pressure %.4f, error %+.1f %%); |C_L| = %.1e; reference 1.09\n",
              r.nx, r.ny, r.nz, r.steps, r.poisson_iterations, r.seconds, r.cd_forcing, 100 * (r.cd_forcing / 1.09 - 1), r.cd,
              r.cd_pressure, 100 * (r.cd / 1.09 - 1), r.cl);
}

// CI grid: h = D/12, ratio 1.1, t = 12 D/U. Tolerances: momentum-exchange C_D within 10 % of 1.09 (the
// target); surface-integral C_D within 20 % (its probes at 1.5 and 2.5 cells = 0.12 and 0.21 D lie across
// the boundary layer at this resolution and under-read the wall shear and the stagnation pressure;
// docs/validation.md); no lift (< 1e-2).
TEST(ImmersedSphere, SteadyDragAtRe100) {
  const SphereResult r = run_sphere(1.0 / 12, 1.1, 12, 12);
  print(r);
  EXPECT_NEAR(r.cd_forcing, 1.09, 0.109);
  EXPECT_NEAR(r.cd, 1.09, 0.218);
  EXPECT_LT(r.cl, 0.01);
}

// ---------------------------------------------------------------------------------------------------------------
// Oscillating sphere (Stokes) and the fixed sphere in an oscillating far field

struct Oscillation {
  double amplitude, phase;  // fitted first harmonic of F_x: F ~ c + amplitude sin(omega t + phase)
  double ref_amplitude, ref_phase;
  double spike;             // max |F - fit (harmonics 0..3)| over the fitted period, relative to the amplitude
  int cells, steps;
  double seconds;
};

// Least-squares fit of harmonics 0..3 of omega to f(t); fills amplitude, phase and spike.
void fit_harmonics(const std::vector<double>& ts, const std::vector<double>& fs, double omega, Oscillation& o) {
  Eigen::MatrixXd M(Eigen::Index(ts.size()), 7);
  Eigen::VectorXd b(Eigen::Index(ts.size()));
  for (std::size_t m = 0; m < ts.size(); ++m) {
    const double th = omega * ts[m];
    M.row(Eigen::Index(m)) << 1, std::sin(th), std::cos(th), std::sin(2 * th), std::cos(2 * th), std::sin(3 * th), std::cos(3 * th);
    b[Eigen::Index(m)] = fs[m];
  }
  const Eigen::VectorXd c = M.colPivHouseholderQr().solve(b);
  o.amplitude = std::hypot(c[1], c[2]);
  o.phase = std::atan2(c[2], c[1]);
  o.spike = (M * c - b).cwiseAbs().maxCoeff() / o.amplitude;
}

// R = 0.5, omega = 2 pi, R/delta = 2 (nu = delta^2 omega / 2), u_b = u0 sin(omega t) with A = u0/omega = 0.05 R
// (Re = u0 D / nu = 0.8). Box [-4, 4]^3 (8 R from the centre), walls: at rest (moving sphere) or moving with
// U(t) = -u_b(t) (fixed sphere). Fine box [-0.8, 0.8]^3 with spacing h, stretched by <= 1.1 outside. Fixed dt
// (a whole number per period, within the diffusion limit). Fit over the last of `periods` periods, every step.
// Reference force on the moving sphere (Landau & Lifshitz section 24 problem 5, real coefficients, so valid for
// the real signal): F = -(a u + b du/dt), a = 6 pi mu R (1 + R/delta), b = 3 pi R^2 sqrt(2 mu rho/omega)
// (1 + 2R/(9 delta)). The fixed sphere in the oscillating flow feels F_moving + rho V dU/dt (Froude-Krylov: the
// far-field pressure gradient -rho dU/dt acting on the sphere's volume), so F_fixed - rho V dU/dt is compared.
// Returns {surface integral (loads), momentum exchange (exchange_loads)}.
std::array<Oscillation, 2> run_oscillating(double h, int periods, bool moving, int mesh_n) {
  const auto t0 = std::chrono::steady_clock::now();
  using Case = flapstab::testing::OscillatingSphere;
  const double R = Case::R, omega = Case::omega, delta = Case::delta, nu = Case::nu, u0 = Case::u0;
  const double V = 4.0 / 3.0 * pi * R * R * R;
  Case flow(h, moving, mesh_n);
  const Grid& g = flow.grid;
  const int per_period = flow.per_period;
  Solver& s = flow.solver;
  ImmersedBoundary& ib = flow.ib;
  std::vector<double> ts, fs, fe;
  for (int n = 0; n < periods * per_period; ++n) {
    s.step();
    if (n >= (periods - 1) * per_period) {
      const double fk = moving ? 0.0 : V * (-u0 * omega * std::cos(omega * s.time()));  // rho V dU/dt
      ts.push_back(s.time());
      fs.push_back(ib.loads(s, Vec3::Zero())[0].force().x() - fk);
      fe.push_back(ib.exchange_loads(s, Vec3::Zero())[0].force().x() - fk);
    }
  }
  std::array<Oscillation, 2> o{};
  fit_harmonics(ts, fs, omega, o[0]);
  fit_harmonics(ts, fe, omega, o[1]);
  const double mu = nu, ca = 6 * pi * mu * R * (1 + R / delta), cb = 3 * pi * R * R * std::sqrt(2 * mu / omega) * (1 + 2 * R / (9 * delta));
  for (Oscillation& x : o) {
    x.ref_amplitude = u0 * std::hypot(ca, cb * omega);  // of -(a u0 sin + b u0 omega cos)
    x.ref_phase = std::atan2(-cb * u0 * omega, -ca * u0);
    x.cells = int(g.cells());
    x.steps = periods * per_period;
    x.seconds = seconds_since(t0);
  }
  return o;
}

void print(const char* what, const Oscillation& o) {
  std::printf("  %s (%d cells, %d steps, %.1f s): amplitude %.4f (Stokes %.4f, error %+.1f %%), phase %.2f deg (Stokes %.2f, "
              "error %+.2f deg), spike metric %.2e\n",
              what, o.cells, o.steps, o.seconds, o.amplitude, o.ref_amplitude, 100 * (o.amplitude / o.ref_amplitude - 1),
              o.phase * 180 / pi, o.ref_phase * 180 / pi, (o.phase - o.ref_phase) * 180 / pi, o.spike);
}

double degrees(double a) { return a * 180 / pi; }

// CI grid h = D/12 = delta/3, 3 periods, moving and fixed sphere. Tolerances (momentum-exchange loads, the
// accurate ones on this grid): amplitude 10 %, phase 5 degrees against Stokes; fixed sphere in the oscillating
// flow minus rho V dU/dt against the moving sphere: amplitude 3 %, phase 2 degrees. Smoothness (no fresh-cell
// spikes): the force departs from its harmonics 0..3 by < 2 % of the amplitude (surface integral) and < 5 %
// (momentum exchange, which sees each face's switch directly). The surface integral's amplitude is
// resolution-limited here (probes 1.5 and 2.5 cells out, in a Stokes layer 3 cells thick): phase within
// 5 degrees, amplitude within 25 % (docs/validation.md).
TEST(ImmersedOscillatingSphere, StokesForceFreshCellsAndFixedSphereInOscillatingFlow) {
  const auto m = run_oscillating(1.0 / 12, 3, true, 12), f = run_oscillating(1.0 / 12, 3, false, 12);
  print("moving sphere, surface integral", m[0]);
  print("moving sphere, momentum exchange", m[1]);
  print("fixed sphere in oscillating flow - rho V dU/dt, surface integral", f[0]);
  print("fixed sphere in oscillating flow - rho V dU/dt, momentum exchange", f[1]);
  EXPECT_NEAR(m[1].amplitude / m[1].ref_amplitude, 1.0, 0.10);
  EXPECT_NEAR(degrees(m[1].phase - m[1].ref_phase), 0.0, 5.0);
  EXPECT_NEAR(m[0].amplitude / m[0].ref_amplitude, 1.0, 0.25);
  EXPECT_NEAR(degrees(m[0].phase - m[0].ref_phase), 0.0, 5.0);
  EXPECT_LT(m[0].spike, 0.02);
  EXPECT_LT(m[1].spike, 0.05);
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(f[k].amplitude / m[k].amplitude, 1.0, 0.03);
    EXPECT_NEAR(degrees(f[k].phase - m[k].phase), 0.0, 2.0);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Membrane disk broadside, Re = 20

struct DiskResult {
  double cd, side, cd_pressure, cd_forcing;
  double seconds;
  int cells;
};

// Disk diameter d = 1 (zero thickness), U = 1, Re = U d / nu = 20, domain [-4, 8] x [-4, 4]^2, fine box
// [-0.4, 1] x [-0.7, 0.7]^2 with spacing h, stretched by <= 1.1; inflow U at x-, outflow at x+, velocity U on
// the lateral faces; C_D averaged over the last 1 d/U before t_end.
DiskResult run_disk(double h, double t_end) {
  const auto t0 = std::chrono::steady_clock::now();
  const Grid g(Axis::stretched(StretchedAxis{-4, 8, -0.4, 1.0, h, 1.1, 8}, false),
               Axis::stretched(StretchedAxis{-4, 4, -0.7, 0.7, h, 1.1, 8}, false),
               Axis::stretched(StretchedAxis{-4, 4, -0.7, 0.7, h, 1.1, 8}, false));
  Boundaries bc = Boundaries::all(BC::velocity);
  for (auto& f : bc.face) f.velocity = [](double) { return Vec3(1, 0, 0); };
  bc.face[face(0, 1)] = {BC::outflow, {}, {}};
  SolverOptions opt;
  opt.nu = 1.0 / 20;
  opt.cfl = 1.2;
  Solver s(g, bc, opt);
  s.initialise([](double, double, double) { return Vec3(1, 0, 0); });
  ImmersedBoundary ib(g);
  ib.add_part(disk_mesh(0.5, 12, 48), fixed_part());
  ib.attach(s);
  const double q = 0.5 * pi / 4;
  double sum = 0, sums = 0, sump = 0, sumf = 0;
  int n = 0;
  while (s.time() < t_end) {
    s.step();
    if (s.time() > t_end - 1) {
      const PartLoads L = ib.loads(s, Vec3::Zero())[0];
      sum += L.force().x() / q, sump += L.pressure_force.x() / q, sums += std::hypot(L.force().y(), L.force().z()) / q;
      sumf += ib.exchange_loads(s, Vec3::Zero())[0].force().x() / q;
      ++n;
    }
  }
  return {sum / n, sums / n, sump / n, sumf / n, seconds_since(t0), int(g.cells())};
}

double disk_cd_clift(double re) {
  const double l = std::log10(re);
  return 64 / (pi * re) * (1 + std::pow(10.0, -0.883 + 0.906 * l - 0.025 * l * l));
}

// CI grid h = d/10. Tolerances: momentum-exchange drag within 25 % of the correlation (the correlation's own
// scatter is ~10 %; the lateral faces at 8 d add blockage at this Reynolds number; the membrane is forced over
// 1.2 cells, which widens the disk by ~0.6 h = 0.06 d per side); no side force (< 1e-3 C_D). The surface
// integral's drag is recorded, not asserted (its probes sit 2.1 and 3.1 cells from the mid-surface, 0.2-0.3 d).
TEST(ImmersedMembrane, DiskBroadsideDragAtRe20) {
  const DiskResult r = run_disk(0.1, 8);
  const double ref = disk_cd_clift(20);
  std::printf("  membrane disk Re 20 (%d cells, %.1f s): momentum exchange C_D = %.3f (error %+.1f %%); surface integral C_D = "
              "%.3f (pressure %.3f, error %+.1f %%); side %.1e; Clift et al. %.3f\n",
              r.cells, r.seconds, r.cd_forcing, 100 * (r.cd_forcing / ref - 1), r.cd, r.cd_pressure, 100 * (r.cd / ref - 1), r.side, ref);
  EXPECT_NEAR(r.cd_forcing / ref, 1.0, 0.25);
  EXPECT_LT(r.side, 1e-3 * r.cd);
}

// ---------------------------------------------------------------------------------------------------------------
// Converged versions (docs/validation.md): run with
//   ./build/tests/test_cfd --gtest_also_run_disabled_tests --gtest_filter='ImmersedConverged*'

// Converged grid h = D/24, ratio 1.05, t = 16 D/U: momentum-exchange C_D within 3 % of 1.09; surface integral
// within 10 %.
TEST(ImmersedConverged, DISABLED_SphereSteadyDragAtRe100) {
  const SphereResult r = run_sphere(1.0 / 24, 1.05, 16, 24);
  print(r);
  EXPECT_NEAR(r.cd_forcing, 1.09, 0.0327);
  EXPECT_NEAR(r.cd, 1.09, 0.109);
}

// Grid study of the two load estimates on the CI family (ratio 1.1, t = 12): D/12, D/16, D/24 (about 5 min on
// one thread). Run with --gtest_also_run_disabled_tests --gtest_filter='ImmersedStudy*'. Records, asserts
// only that both estimates move toward each other.
TEST(ImmersedStudy, DISABLED_SphereDragGridStudy) {
  double gap = 1e300;
  for (int n : {12, 16, 24}) {
    const SphereResult r = run_sphere(1.0 / n, 1.1, 12, n);
    print(r);
    EXPECT_LT(r.cd_forcing - r.cd, gap);
    gap = r.cd_forcing - r.cd;
  }
}

TEST(ImmersedConverged, DISABLED_OscillatingSphere) {
  const auto m = run_oscillating(1.0 / 20, 3, true, 20), f = run_oscillating(1.0 / 20, 3, false, 20);
  print("moving sphere, surface integral", m[0]);
  print("moving sphere, momentum exchange", m[1]);
  print("fixed sphere in oscillating flow - rho V dU/dt, surface integral", f[0]);
  print("fixed sphere in oscillating flow - rho V dU/dt, momentum exchange", f[1]);
  EXPECT_NEAR(m[1].amplitude / m[1].ref_amplitude, 1.0, 0.05);
  EXPECT_NEAR(degrees(m[1].phase - m[1].ref_phase), 0.0, 3.0);
  EXPECT_LT(m[0].spike, 0.02);
  EXPECT_NEAR(f[1].amplitude / m[1].amplitude, 1.0, 0.02);
}

// Cost of the immersed boundary per Runge-Kutta stage on an insect-like case (docs/validation.md): 128^3 = 2.1 M
// cells of h = 3/128 over [-1.5, 1.5]^3; a closed ellipsoid body (1 x 0.3 x 0.3) and two membrane wings
// (elliptic, R = 1, mean chord 0.3, 40 x 10 stations), flapping +-60 degrees about the body's z axis with a
// +-45 degree pitch about the span. Times after_predictor + after_projection over 24 stage times of a wingbeat
// (no flow solve). Prints, asserts nothing about time.
TEST(ImmersedConverged, DISABLED_CostPerStage) {
  const int n = 128;
  const Grid g(Axis::uniform(-1.5, 1.5, n, false), Axis::uniform(-1.5, 1.5, n, false), Axis::uniform(-1.5, 1.5, n, false));
  SolverOptions opt;
  opt.nu = 0.01;
  Solver s(g, Boundaries::all(BC::velocity), opt);
  ImmersedBoundary ib(g);
  const auto t_build = std::chrono::steady_clock::now();
  ib.add_part(ellipsoid_mesh(Vec3(1.0, 0.3, 0.3), 16), fixed_part());
  flapstab::Wing w;
  w.length = 1;
  w.mean_chord = 0.3;
  const TriangleMesh wing = wing_mesh(w, 40, 10);
  for (int side = 0; side < 2; ++side) {
    const double sgn = side == 0 ? 1 : -1;
    const Vec3 hinge(0.1, 0.15 * sgn, 0.1);
    ib.add_part(wing, [=](double t) {
      const double phi = (pi / 3) * std::sin(2 * pi * t), dphi = (pi / 3) * 2 * pi * std::cos(2 * pi * t);
      const double th = (pi / 4) * std::cos(2 * pi * t), dth = -(pi / 4) * 2 * pi * std::sin(2 * pi * t);
      Mat3 mirror = Mat3::Identity();
      mirror(1, 1) = sgn;
      const Mat3 Rz = Eigen::AngleAxisd(sgn * phi, Vec3::UnitZ()).toRotationMatrix();
      const Mat3 Ry = Eigen::AngleAxisd(th, Vec3::UnitY()).toRotationMatrix();
      const Mat3 R = Rz * mirror * Ry;
      const Vec3 omega = Vec3(0, 0, sgn * dphi) + Rz * mirror * Vec3(0, dth, 0) * (mirror.determinant());
      return PartState{RigidTransform{R, hinge}, RigidVelocity{hinge, Vec3::Zero(), omega}};
    });
  }
  const double build = seconds_since(t_build);
  s.initialise([](double, double, double) { return Vec3(0.1, 0, 0); });
  ib.attach(s);
  VectorField u = s.velocity();
  Field p = s.pressure();
  const int calls = 24;
  const auto t0 = std::chrono::steady_clock::now();
  for (int c = 0; c < calls; ++c) {
    ib.after_predictor(u, c / double(calls), 1e-3);
    ib.after_projection(u, p, c / double(calls));
  }
  const double per_stage = seconds_since(t0) / calls;
  std::printf("  IB cost, insect-like case on %d^3: level sets built in %.2f s, %.1f MB; per stage %.2f ms = %.2f ns per cell "
              "(%.2f ns per cell per step of 3 stages); last stage %zu solid + %zu band faces\n",
              n, build, ib.bytes() / 1e6, 1e3 * per_stage, 1e9 * per_stage / double(g.cells()),
              3e9 * per_stage / double(g.cells()), ib.solid_faces(), ib.band_faces());
  // Whole steps from a Taylor-Green-like field (so the Poisson solves do real work in both), with the flapping
  // parts and without them.
  auto per_step = [&](bool with_ib, double& iterations) {
    Solver sv(g, Boundaries::all(BC::velocity), SolverOptions{.nu = 0.01, .dt = 2e-3});
    const double k = pi / 1.5;
    sv.initialise([k](double x, double y, double z) {
      return Vec3(std::sin(k * x) * std::cos(k * y) * std::cos(k * z), -std::cos(k * x) * std::sin(k * y) * std::cos(k * z), 0);
    });
    if (with_ib) ib.attach(sv);
    for (int m = 0; m < 3; ++m) sv.step();
    iterations = 0;
    const auto t1 = std::chrono::steady_clock::now();
    for (int m = 0; m < 6; ++m) {
      sv.step();
      for (const auto& st : sv.poisson_stats()) iterations += st.cycles / 6.0;
    }
    return seconds_since(t1) / 6;
  };
  double it_bare, it_with;
  const double bare = per_step(false, it_bare), with = per_step(true, it_with);
  std::printf("  whole step on %d^3: %.1f ns per cell without parts (%.1f Poisson iterations per step), %.1f ns per cell with the body "
              "and flapping wings (%.1f iterations; +%.0f %%)\n",
              n, 1e9 * bare / double(g.cells()), it_bare, 1e9 * with / double(g.cells()), it_with, 100 * (with / bare - 1));
}

}  // namespace
