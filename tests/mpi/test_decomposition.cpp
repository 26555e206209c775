// The Navier-Stokes solver decomposed into z slabs over MPI ranks, against the same solver on one rank. Run under
// mpiexec (tests/CMakeLists.txt: 2 ranks, and 3 for an uneven split). Every rank also runs the single-rank solver
// on the whole grid and compares its slab, ghost planes included, with the decomposed result:
// - one multigrid V-cycle: bit for bit (every cell sees the single-rank arithmetic; the coarse levels are gathered);
// - a pressure solve: to round-off (the Krylov inner products are summed in another order);
// - time steps of a three-dimensional Taylor-Green vortex in a periodic box (the z axis a ring of ranks), and of a
//   flow through a walled box with stretched axes, an inflow and an outflow face, a sponge layer and a turning
//   frame (the slabs' end ranks at walls): to round-off of the velocity scale.
// Nothing here is timed; bench/bench_mpi_scaling.cpp (bench/mpi_scaling.sh) measures the speed-up.
#include <gtest/gtest.h>
#include <mpi.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include "cfd/navier_stokes/poisson.hpp"
#include "cfd/navier_stokes/poisson_hypre.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "cfd/navier_stokes/simulation.hpp"
#include "common/case_text.hpp"
#include "core/case_file.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "cfd/navier_stokes/run.hpp"
#include "cfd/navier_stokes/solver.hpp"
#include "cfd/navier_stokes/solver_io.hpp"
#include "core/errors.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::BodyMotion;
using flapstab::Case;
using flapstab::Vec3;

std::shared_ptr<const Decomposition> world() {
  static const auto d = Decomposition::world();
  return d;
}

// max over the slab's padded points of |local - whole at the same global point|, and the largest |whole| there.
// up_to_a_constant: the spread (largest minus smallest) of the difference over all ranks' slabs instead, for a
// pressure fixed only up to a constant (all faces periodic or walls), whose constant round-off moves.
struct Difference {
  double max = 0, scale = 0;
};
Difference compare(const Field& local, const Field& whole, const Slab& sl, bool up_to_a_constant = false) {
  Difference d;
  double lo = 1e300, hi = -1e300;
  const Shape& s = local.shape();
  for (int k = 0; k <= s.nz + 1; ++k)
    for (int j = 0; j <= s.ny + 1; ++j)
      for (int i = 0; i <= s.nx + 1; ++i) {
        const double e = double(local(i, j, k)) - whole(i, j, k + sl.offset);
        lo = std::min(lo, e);
        hi = std::max(hi, e);
        d.max = std::max(d.max, std::abs(e));
        d.scale = std::max(d.scale, std::abs(double(whole(i, j, k + sl.offset))));
      }
  if (up_to_a_constant) d.max = world()->max(hi) + world()->max(-lo);
  return d;
}

// A smooth right-hand side with all scales (the sum of a few modes and a local bump), zero volume-weighted mean
// left to the solver.
double rhs(const std::array<double, 3>& x) {
  return std::sin(3 * x[0]) * std::cos(2 * x[1]) * std::sin(5 * x[2] + 0.3) +
         std::exp(-20 * (x[0] * x[0] + x[2] * x[2]));
}

Field whole_rhs(const Grid& g) {
  Field b(g.shape());
  for (int k = 1; k <= g.shape().nz; ++k)
    for (int j = 1; j <= g.shape().ny; ++j)
      for (int i = 1; i <= g.shape().nx; ++i) b(i, j, k) = rhs(g.centre(i, j, k));
  return b;
}

// A rank's planes of a whole field (shape: the slab's).
Field slab_of(const Field& whole, const Shape& shape, const Slab& sl) {
  Field f(shape);
  for (int k = 1; k <= sl.n; ++k)
    for (int j = 1; j <= shape.ny; ++j)
      for (int i = 1; i <= shape.nx; ++i) f(i, j, k) = whole(i, j, k + sl.offset);
  return f;
}

Grid walled_grid(int nx, int ny, int nz) {
  StretchedAxis zs{.lo = -2, .hi = 2.5, .box_lo = -0.5, .box_hi = 0.5, .h = 4.5 / (1.2 * nz), .max_ratio = 1.08,
                   .multiple_of = 8};
  Axis z = Axis::stretched(zs, false);
  StretchedAxis xs{.lo = -1.5, .hi = 1.5, .box_lo = -0.4, .box_hi = 0.6, .h = 3.0 / (1.5 * nx), .max_ratio = 1.06,
                   .multiple_of = 8};
  return Grid(Axis::stretched(xs, false), Axis::uniform(-1, 1, ny, false), std::move(z));
}

TEST(Decomposition, SlabsAreWholeBlocksAndCoverTheAxis) {
  const auto& D = *world();
  const Grid g = walled_grid(24, 16, 40);
  const int unit = Multigrid::z_unit(g, D.size());
  const auto slabs = D.slabs(g.axis[2].n, unit, false);
  int at = 0;
  for (const Slab& s : slabs) {
    EXPECT_EQ(s.offset, at);
    EXPECT_EQ(s.n % unit, 0);
    at += s.n;
  }
  EXPECT_EQ(at, g.axis[2].n);
  EXPECT_FALSE(slabs.front().cut_lo);
  EXPECT_FALSE(slabs.back().cut_hi);
  if (D.rank() == 0)
    std::printf("[ rank 0 ] z axis of %d cells in blocks of %d planes: %d ranks hold", g.axis[2].n, unit, D.size());
  if (D.rank() == 0)
    for (const Slab& s : slabs) std::printf(" %d", s.n);
  if (D.rank() == 0) std::printf(" planes\n");
  EXPECT_THROW(D.slabs(g.axis[2].n, g.axis[2].n, false), std::invalid_argument);  // one block for several ranks
}

// A failure of rank 0's part (a file it writes for all) becomes every rank's, of the same kind, so that no rank goes
// on into a collective operation rank 0 has left; a success is every rank's too.
TEST(Decomposition, RankZerosFailureIsEveryRanks) {
  const Decomposition& D = *world();
  int calls = 0;
  on_root(D, [&] { ++calls; });
  EXPECT_EQ(calls, D.rank() == 0 ? 1 : 0);
  auto fail = [&](auto error) {
    on_root(D, [&] { throw error; });
  };
  EXPECT_THROW(fail(flapstab::InputError("f.toml", "key", "bad")), flapstab::InputError);
  EXPECT_THROW(fail(flapstab::OutputError("disk full")), flapstab::OutputError);
  EXPECT_THROW(fail(flapstab::SolveError("diverged")), flapstab::SolveError);
  EXPECT_THROW(fail(std::logic_error("bug")), RanksFailed);
  try {
    fail(flapstab::OutputError("disk full"));
  } catch (const flapstab::OutputError& e) {  // rank 0 keeps its message; the others say whose it is
    EXPECT_EQ(std::string(e.what()), D.rank() == 0 ? "disk full" : "rank 0 failed (its message says why)");
  }
  EXPECT_EQ(D.max(1.0), 1.0);  // and the ranks are still in step
}

// from_root gives every rank rank 0's answer (a file it read, a lock it took), also after rank 0 took its time (the
// others wait in a non-blocking broadcast), and a long text whole.
TEST(Decomposition, RankZerosAnswerIsEveryRanks) {
  const Decomposition& D = *world();
  const std::string answer = from_root(D, [&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    return "rank " + std::to_string(D.rank()) + " read it";
  });
  EXPECT_EQ(answer, "rank 0 read it");
  const std::string empty = from_root(D, [] { return std::string(); });
  EXPECT_EQ(empty, "");
  const std::string longer = from_root(D, [&] { return std::string(1 << 20, char('a' + D.rank())); });
  EXPECT_EQ(longer, std::string(1 << 20, 'a'));
  EXPECT_THROW(from_root(D, []() -> std::string { throw flapstab::InputError("f.toml", "key", "bad"); }),
               flapstab::InputError);
  EXPECT_EQ(D.max(1.0), 1.0);
}

TEST(Decomposition, VCycleIsBitForBitTheSingleRankOne) {
  for (bool periodic : {false, true}) {
    const Grid g = periodic ? Grid(Axis::uniform(-1, 1, 16, true), Axis::uniform(-1, 1, 24, true),
                                   Axis::uniform(-1, 1.5, 48, true))
                            : walled_grid(24, 16, 40);
    ScalarBCs bc;
    bc.fill(periodic ? ScalarBC::periodic : ScalarBC::neumann);
    if (!periodic) bc[face(2, 1)] = ScalarBC::dirichlet;
    Multigrid whole(g, bc);
    Multigrid part(g, bc, world());
    const Slab sl = Multigrid::rank_slab(g, *world());
    const Grid local = g.slice_z(sl);
    Field rw = whole_rhs(g), zw(g.shape()), rl = slab_of(rw, local.shape(), sl), zl(local.shape());
    whole.vcycle(rw, zw, 2, 2);
    part.vcycle(rl, zl, 2, 2);
    double diff = 0;
    for (int k = 1; k <= sl.n; ++k)
      for (int j = 1; j <= g.shape().ny; ++j)
        for (int i = 1; i <= g.shape().nx; ++i) diff = std::max(diff, std::abs(zl(i, j, k) - zw(i, j, k + sl.offset)));
    EXPECT_EQ(diff, 0.0) << (periodic ? "periodic" : "walled") << " box; gathered level " << part.gathered_level()
                         << " of " << part.levels();
    EXPECT_GT(part.gathered_level(), 0);
  }
}

TEST(Decomposition, PressureSolveMatchesTheSingleRankOneToRoundOff) {
  const Grid g = walled_grid(24, 16, 40);
  ScalarBCs bc;
  bc.fill(ScalarBC::neumann);  // singular: the volume-weighted mean is removed over all ranks
  Poisson whole(g, bc);
  Poisson part(g, bc, world());
  const Slab& sl = part.slab();
  Field bw = whole_rhs(g), xw(g.shape()), bl = slab_of(bw, g.slice_z(sl).shape(), sl), xl(bl.shape());
  PoissonOptions opt{.rtol = 1e-10, .max_cycles = 60};
  const PoissonStats sw = whole.solve(xw, bw, opt);
  const PoissonStats sp = part.solve(xl, bl, opt);
  EXPECT_TRUE(sw.converged && sp.converged);
  EXPECT_EQ(sw.cycles, sp.cycles);
  // The residuals are differences of O(1) terms: equal to the round-off of the right-hand side's scale.
  EXPECT_NEAR(sp.residual, sw.residual, 1e-13 * sw.initial_residual);
  const Difference d = compare(xl, xw, sl, true);
  EXPECT_LE(d.max, 1e-12 * d.scale) << "max |x| " << d.scale;
  if (world()->rank() == 0)
    std::printf("[ rank 0 ] pressure solve, %d iterations: spread of the difference %.3g of %.3g\n", sp.cycles, d.max,
                d.scale);
}

// hypre's structured PCG + SMG over the ranks (each rank gives its slab as a box of the whole grid) against the
// single-rank multigrid solve converged to 1e-13: the same discrete solution, to the solver's tolerance. SMG's
// smoothing depends on the boxes, so the iterates differ from hypre's on one rank; each solution is within
// |L^-1| |r| of the exact discrete one, |r| <= rtol |b| (max norm) and |L^-1| of order (box size / pi)^2 ~ 1 here.
TEST(Decomposition, HypreOverRanksGivesTheSingleRankSolutionToItsTolerance) {
  if (!hypre_available()) GTEST_SKIP() << "hypre not built in";
  const Grid g = walled_grid(24, 16, 40);
  ScalarBCs bc;
  bc.fill(ScalarBC::neumann);
  bc[face(2, 1)] = ScalarBC::dirichlet;
  Poisson whole(g, bc);
  Poisson part(g, bc, world());
  const Slab& sl = part.slab();
  Field bw = whole_rhs(g), xw(g.shape()), bl = slab_of(bw, g.slice_z(sl).shape(), sl), xl(bl.shape());
  const PoissonStats sw = whole.solve(xw, bw, PoissonOptions{.rtol = 1e-13, .max_cycles = 80});
  const PoissonStats sp =
      part.solve(xl, bl, PoissonOptions{.backend = PoissonBackend::hypre, .rtol = 1e-10, .max_cycles = 200});
  EXPECT_TRUE(sw.converged);
  EXPECT_TRUE(sp.converged) << sp.residual << " after " << sp.cycles << " iterations, target " << sp.target;
  const Difference d = compare(xl, xw, sl);
  EXPECT_LE(d.max, 1e-9 * d.scale) << "max |x| " << d.scale;
  if (world()->rank() == 0)
    std::printf("[ rank 0 ] hypre over %d ranks: %d iterations, max difference %.3g of %.3g from the multigrid\n",
                world()->size(), sp.cycles, d.max, d.scale);
}

// Steps of the single-rank and the decomposed solver; the velocity and pressure differences over the slab.
struct Comparison {
  double du = 0, dp = 0, u = 0, p = 0;
  double energy_whole = 0, energy_part = 0;
};
// part_backend: the decomposed solver's pressure solver (the single-rank one keeps the multigrid).
Comparison run_both(const Grid& g, const Boundaries& bc, const SolverOptions& opt,
                    const std::function<Vec3(double, double, double)>& u0, int steps, bool singular,
                    PoissonBackend part_backend = PoissonBackend::multigrid) {
  Solver whole(g, bc, opt);
  SolverOptions part_opt = opt;
  part_opt.poisson.backend = part_backend;
  Solver part(g, bc, part_opt, world());
  whole.initialise(u0);
  part.initialise(u0);
  for (int n = 0; n < steps; ++n) {
    const double dw = whole.step(), dp = part.step();
    EXPECT_NEAR(dw, dp, 1e-12 * dw) << "step " << n;  // the adaptive step from velocities equal to round-off
  }
  Comparison c;
  for (int d = 0; d < 3; ++d) {
    const Difference e = compare(part.velocity()[d], whole.velocity()[d], part.slab());
    c.du = std::max(c.du, e.max);
    c.u = std::max(c.u, e.scale);
  }
  const Difference e = compare(part.pressure(), whole.pressure(), part.slab(), singular);
  c.dp = e.max;
  c.p = e.scale;
  c.energy_whole = whole.kinetic_energy();
  c.energy_part = part.kinetic_energy();
  return c;
}

// A flow through the walled box: inflow at z-, outflow at z+, walls at rest elsewhere.
struct WalledCase {
  Grid g = walled_grid(24, 16, 40);
  Boundaries bc = Boundaries::all(BC::velocity);
  SolverOptions opt;
  static Vec3 u0(double x, double y, double z) {
    return Vec3(0.1 + 0.5 * std::sin(2 * y) * std::exp(-z * z), 0.3 * std::cos(3 * x), 1.0 + 0.4 * std::sin(2 * x + z));
  }
  // Both solvers from u0, then `steps` steps each.
  static void start(Solver& a, Solver& b, int steps) {
    for (Solver* s : {&a, &b}) {
      s->initialise(u0);
      for (int n = 0; n < steps; ++n) s->step();
    }
  }
  WalledCase() {
    bc.face[face(2, 0)].velocity = [](double) { return Vec3(0.1, 0.0, 1.0); };
    bc.face[face(2, 1)] = FaceCondition{BC::outflow, {}, {}};
    opt.nu = 0.02;
    opt.dt = 0.02;
    opt.poisson.rtol = 1e-8;
  }
};

// The checks of a run_both comparison to round-off: velocity, pressure (to 1e-10 of its scale: it carries the
// projections' increments, each from a solve to its tolerance) and kinetic energy.
void expect_round_off(const Comparison& c, const char* what) {
  EXPECT_LE(c.du, 1e-11 * c.u) << what << ": max |u| " << c.u;
  EXPECT_LE(c.dp, 1e-10 * c.p) << what << ": max |p| " << c.p;
  EXPECT_NEAR(c.energy_part, c.energy_whole, 1e-12 * c.energy_whole) << what;
  if (world()->rank() == 0)
    std::printf("[ rank 0 ] %s: max velocity difference %.3g of %.3g, pressure %.3g of %.3g\n", what, c.du, c.u, c.dp,
                c.p);
}

TEST(Decomposition, TaylorGreenVortexInAPeriodicBox) {
  const double L = 2 * M_PI;
  const Grid g(Axis::uniform(0, L, 24, true), Axis::uniform(0, L, 24, true), Axis::uniform(0, L, 32, true));
  SolverOptions opt;
  opt.nu = 0.01;
  opt.cfl = 0.8;
  opt.poisson.rtol = 1e-8;
  const Comparison c = run_both(g, Boundaries::all(BC::periodic), opt,
                                [](double x, double y, double z) {
                                  return Vec3(std::sin(x) * std::cos(y) * std::cos(z),
                                              -std::cos(x) * std::sin(y) * std::cos(z), 0.0);
                                },
                                12, true);
  expect_round_off(c, "Taylor-Green, 12 steps");
}

TEST(Decomposition, FlowThroughAWalledBoxWithASpongeInATurningFrame) {
  const Grid g = walled_grid(24, 16, 40);
  Boundaries bc = Boundaries::all(BC::velocity);
  const Vec3 Omega(0.3, -0.2, 0.5);
  for (auto& f : bc.face)  // the far field seen from the turning frame, a stream along +z
    f.field = [Omega](double, const Vec3& x) { return Vec3(Vec3(0.1, 0.0, 1.0) - Omega.cross(x)); };
  bc.face[face(2, 1)] = FaceCondition{BC::outflow, {}, {}};
  SolverOptions opt;
  opt.nu = 0.02;
  opt.cfl = 0.8;
  opt.frame_rate = Omega;
  opt.poisson.rtol = 1e-8;
  opt.sponge.width = {0, 0, 0, 0, 0.6, 0.8};
  opt.sponge.rate = 4;
  opt.sponge.velocity = Vec3(0.1, 0.0, 1.0);
  expect_round_off(run_both(g, bc, opt, WalledCase::u0, 10, false), "walled box, 10 steps");
}

// The walled box's steps with hypre's pressure solver over the ranks against the single-rank multigrid, both to
// 1e-10: the two solves leave different divergence residuals (each below 1e-10 of the predictor's divergence), so
// the velocities agree to the solver tolerance, not to round-off.
TEST(Decomposition, HypreOverRanksInTheTimeStep) {
  if (!hypre_available()) GTEST_SKIP() << "hypre not built in";
  const WalledCase w;
  SolverOptions opt = w.opt;
  opt.poisson.rtol = 1e-10;
  opt.poisson.max_cycles = 100;
  const Comparison c = run_both(w.g, w.bc, opt, WalledCase::u0, 5, false, PoissonBackend::hypre);
  EXPECT_LE(c.du, 1e-10 * c.u) << "max |u| " << c.u;  // the solves' tolerance
  EXPECT_LE(c.dp, 1e-9 * c.p) << "max |p| " << c.p;
  if (world()->rank() == 0)
    std::printf("[ rank 0 ] hypre in the time step, 5 steps: max velocity difference %.3g of %.3g, pressure %.3g of "
                "%.3g\n", c.du, c.u, c.dp, c.p);
}

std::string shared_path(const std::string& name) {  // the same on every rank (rank 0 writes)
  return ::testing::TempDir() + "flapstab_mpi_" + std::to_string(world()->size()) + "_" + name;
}
std::string own_path(const std::string& name) {  // one per rank
  return shared_path(name + "_rank" + std::to_string(world()->rank()));
}

// A checkpoint written over the ranks restarts one rank, and one written by one rank restarts the ranks: the
// checkpoint holds the whole grid whatever wrote it. Each continuation ends where the uninterrupted run does, to
// round-off (the written state is bit for bit the gathered one).
TEST(Decomposition, CheckpointsRestartOnAnotherNumberOfRanks) {
  const WalledCase c;
  Solver part(c.g, c.bc, c.opt, world()), whole(c.g, c.bc, c.opt);
  c.start(part, whole, 4);
  write_solver_checkpoint(shared_path("ranks.h5"), part, 4, c.opt.dt);
  write_solver_checkpoint(own_path("one.h5"), whole, 4, c.opt.dt);  // a single-rank solver: each process its own
  Solver one(c.g, c.bc, c.opt), many(c.g, c.bc, c.opt, world());
  const SimulationState a = read_solver_checkpoint(shared_path("ranks.h5"), one);
  const SimulationState b = read_solver_checkpoint(own_path("one.h5"), many);
  EXPECT_EQ(a.step, 4);
  EXPECT_EQ(b.step, 4);
  EXPECT_EQ(a.time, part.time());
  for (int n = 0; n < 4; ++n) {
    part.step();
    whole.step();
    one.step();
    many.step();
  }
  double du = 0, scale = 0;
  for (int d = 0; d < 3; ++d) {
    const Difference e1 = compare(one.velocity()[d], whole.velocity()[d], Slab{0, c.g.axis[2].n});
    const Difference e2 = compare(many.velocity()[d], whole.velocity()[d], many.slab());
    const Difference e3 = compare(part.velocity()[d], whole.velocity()[d], part.slab());
    du = std::max({du, e1.max, e2.max, e3.max});
    scale = std::max(scale, e1.scale);
  }
  EXPECT_LE(du, 1e-11 * scale) << "max |u| " << scale;
  if (world()->rank() == 0)
    std::printf("[ rank 0 ] restarts across rank counts, 4 + 4 steps: max velocity difference %.3g of %.3g\n", du,
                scale);
  // A checkpoint of another grid is refused, naming the file.
  Solver other(walled_grid(24, 16, 32), c.bc, c.opt, world());
  EXPECT_THROW(read_solver_checkpoint(shared_path("ranks.h5"), other), flapstab::InputError);
}

// A state carried over to another grid over ranks (a free flight's re-planned fine box: rank 0 computes each rank's
// slab of the new grid from the gathered old state and sends it) gives every rank the planes, ghost planes included,
// of the carried-over whole state, bit for bit.
TEST(Decomposition, StateCarriedOverToAnotherGridIsTheWholeTransfersPlanes) {
  const WalledCase c;
  Solver part(c.g, c.bc, c.opt, world()), whole(c.g, c.bc, c.opt);
  c.start(part, whole, 3);
  const Grid other = walled_grid(24, 16, 32);
  Solver target(other, c.bc, c.opt, world());
  const SimulationState gathered = gather_state(part, 3, c.opt.dt);
  const SimulationState mine = transfer_state_over_ranks(gathered, c.g, target);
  EXPECT_EQ(mine.step, 3);
  EXPECT_EQ(mine.time, part.time());
  // The whole old state on every rank (through a checkpoint, bit for bit), carried over to the whole new grid.
  write_state_over_ranks(shared_path("carried.h5"), part, 3, c.opt.dt, {}, {});
  const SimulationState all =
      transfer_state(read_state(CheckpointReader(shared_path("carried.h5")), c.g.shape()), c.g, other);
  const SimulationState expected = own_planes(all, target);
  auto same = [](const Field& a, const Field& b) {
    return a.shape() == b.shape() && std::equal(a.begin(), a.end(), b.begin());
  };
  for (int d = 0; d < 3; ++d) EXPECT_TRUE(same(mine.u[d], expected.u[d])) << "u" << d << " on rank " << world()->rank();
  EXPECT_TRUE(same(mine.p, expected.p)) << "on rank " << world()->rank();
  EXPECT_FALSE(mine.guess);
}

// A checkpoint streamed to rank 0 slab by slab (write_state_over_ranks: no rank holds the whole grid) is the file
// of the gathered state, array for array bit for bit; a checkpoint that rank 0 cannot write fails on every rank,
// and the ranks go on together (no slab left on its way).
TEST(Decomposition, CheckpointStreamedSlabBySlabIsTheGatheredStatesFile) {
  const WalledCase c;
  Solver part(c.g, c.bc, c.opt, world()), whole(c.g, c.bc, c.opt);
  c.start(part, whole, 3);
  write_state_over_ranks(shared_path("streamed.h5"), part, 3, c.opt.dt, {{"extra", 1.5}}, {{"note", "x"}});
  const SimulationState gathered = gather_state(part, 3, c.opt.dt);
  on_root(*world(), [&] { write_state(shared_path("gathered.h5"), gathered, {{"extra", 1.5}}, {{"note", "x"}}); });
  const CheckpointReader a(shared_path("streamed.h5")), b(shared_path("gathered.h5"));
  EXPECT_EQ(a.header().step, 3);
  EXPECT_EQ(a.header().time, b.header().time);
  EXPECT_EQ(a.header().values, b.header().values);
  EXPECT_EQ(a.header().text, b.header().text);
  for (const char* name : {"u0", "u1", "u2", "p", "phi0", "phi1", "phi2"}) {
    EXPECT_EQ(a.shape(name), b.shape(name)) << name;
    EXPECT_TRUE(a.read(name) == b.read(name)) << name;  // each read checks its array's checksum
  }
  EXPECT_THROW(write_state_over_ranks("/dev/null/cannot/streamed.h5", part, 3, c.opt.dt, {}, {}),
               flapstab::OutputError);
  EXPECT_EQ(world()->sum(1.0), double(world()->size()));  // every rank reached here: nothing left hanging
}

// The decomposed solver's field file (gathered on rank 0) holds the single-rank solver's fields to round-off.
TEST(Decomposition, FieldsAreTheWholeGridsFile) {
  const WalledCase c;
  Solver part(c.g, c.bc, c.opt, world()), whole(c.g, c.bc, c.opt);
  c.start(part, whole, 3);
  const RectilinearAxes axes = rectilinear(c.g);
  std::optional<FieldWriter> wp, ww;
  if (world()->rank() == 0) wp.emplace(shared_path("fields_ranks"), "fields", axes);
  ww.emplace(own_path("fields_one"), "fields", axes);
  const std::string fp = write_solver_fields(wp ? &*wp : nullptr, part, 1.2, 3);
  const std::string fw = write_solver_fields(&*ww, whole, 1.2, 3);
  EXPECT_EQ(fp.empty(), world()->rank() != 0);
  if (world()->rank() == 0)
    for (const char* name : {"velocity", "pressure", "vorticity"}) {
      const StoredField a = read_field(fp, name), b = read_field(fw, name);
      ASSERT_EQ(a.values.size(), b.values.size());
      double diff = 0, scale = 0;
      for (std::size_t n = 0; n < a.values.size(); ++n) {
        diff = std::max(diff, std::abs(a.values[n] - b.values[n]));
        scale = std::max(scale, std::abs(b.values[n]));
      }
      EXPECT_LE(diff, 1e-10 * scale) << name;
      std::printf("[ rank 0 ] field file %s: max difference %.3g of %.3g\n", name, diff, scale);
    }
}

// A sphere at Re = 100 in a stream along x (the sphere flow of tests/cfd/test_ns_immersed.cpp on a coarse grid), the
// z axis split across the sphere: the immersed boundary forces each rank's window, the loads are summed over the
// triangles each rank owns. Both load methods and the velocity equal the single rank's to round-off.
TEST(Decomposition, ImmersedSphereLoadsMatchTheSingleRankOnes) {
  const double h = 1.0 / 6;
  const Grid g(Axis::stretched(StretchedAxis{-3, 6, -0.8, 1.6, h, 1.1, 8}, false),
               Axis::stretched(StretchedAxis{-3, 3, -0.8, 0.8, h, 1.1, 8}, false),
               Axis::stretched(StretchedAxis{-3, 3, -0.8, 0.8, h, 1.1, 8}, false));
  Boundaries bc = Boundaries::all(BC::velocity);
  for (auto& f : bc.face) f.velocity = [](double) { return Vec3(1, 0, 0); };
  bc.face[face(0, 1)] = FaceCondition{BC::outflow, {}, {}};
  SolverOptions opt;
  opt.nu = 1.0 / 100;
  opt.dt = 0.05;
  opt.poisson.rtol = 1e-8;
  Solver whole(g, bc, opt), part(g, bc, opt, world());
  ImmersedBoundary ibw(whole.hook_grid()), ibp(part.hook_grid());
  for (auto* ib : {&ibw, &ibp}) ib->add_part(sphere_mesh(0.5, 10), fixed_part());
  const auto stream = [](double, double, double) { return Vec3(1, 0, 0); };
  whole.initialise(stream);
  part.initialise(stream);
  ibw.attach(whole);
  ibp.attach(part);
  double df = 0, dx = 0, f = 0;
  for (int n = 0; n < 10; ++n) {
    whole.step();
    part.step();
    const PartLoads a = ibw.loads(whole, Vec3::Zero())[0], b = ibp.loads(part, Vec3::Zero())[0];
    const PartLoads ea = ibw.exchange_loads(whole, Vec3::Zero())[0], eb = ibp.exchange_loads(part, Vec3::Zero())[0];
    df = std::max({df, (a.force() - b.force()).norm(), (a.moment() - b.moment()).norm(), std::abs(a.power - b.power)});
    dx = std::max({dx, (ea.force() - eb.force()).norm(), (ea.moment() - eb.moment()).norm()});
    f = std::max(f, a.force().norm());
  }
  double du = 0, scale = 0;
  for (int d = 0; d < 3; ++d) {
    const Difference e = compare(part.velocity()[d], whole.velocity()[d], part.slab());
    du = std::max(du, e.max);
    scale = std::max(scale, e.scale);
  }
  EXPECT_GT(f, 0.05);  // the sphere's drag (rho = 1, U = 1, D = 1: C_D of order 1 times pi / 8)
  EXPECT_LE(df, 1e-10 * f) << "surface-integral loads";
  EXPECT_LE(dx, 1e-10 * f) << "momentum-exchange loads";
  EXPECT_LE(du, 1e-11 * scale) << "velocity";
  if (world()->rank() == 0)
    std::printf("[ rank 0 ] immersed sphere, 10 steps: loads differ by %.3g (surface) and %.3g (exchange) of %.3g; "
                "velocity by %.3g of %.3g\n", df, dx, f, du, scale);
}

// The flapping test moth (tests/common/case_text.hpp, the CFD planform) on a coarse grid, ten steps of its wingbeat
// from rest: body and both wings through the Simulation, the grid split over the ranks. Every part's loads equal the
// single rank's to round-off.
Case moth_case(const std::string& extra_keys = "") {
  const std::string keys =
      "cells_per_chord = 5\nfine_margin_R = 0.4\nupstream_R = 0\ndownstream_R = 0\nlateral_R = 0\nabove_R = 0\n"
      "below_R = 0\nsteps_per_cycle = 80\nthreads = 1\n" + extra_keys;
  return flapstab::load_case(flapstab::testing::write_temp(
      "mpi_moth_" + std::to_string(world()->rank()) + ".toml",
      flapstab::testing::replace(flapstab::testing::valid_cfd_case_text(), "[trim]\n",
                                 "[aero.cfd]\n" + keys + "\n[trim]\n")));
}

// Steps both simulations `steps` times: the largest difference of any part's force (and moment / wing length) and
// the largest force.
std::pair<double, double> load_difference(Simulation& a, Simulation& b, int steps, double length) {
  double df = 0, f = 0;
  for (int n = 0; n < steps; ++n) {
    const StepReport ra = a.advance(), rb = b.advance();
    for (int i = 0; i < a.part_count(); ++i) {
      const flapstab::Wrench wa = ra.row.part[i].wrench(), wb = rb.row.part[i].wrench();
      df = std::max({df, (wa.force - wb.force).norm(), (wa.moment - wb.moment).norm() / length});
      f = std::max(f, wa.force.norm());
    }
  }
  return {df, f};
}

TEST(Decomposition, FlappingInsectLoadsMatchTheSingleRankOnes) {
  const Case c = moth_case();
  const CfdPlan plan = plan_cfd(c, c.kinematics, BodyMotion{});
  // Pressure solves to 1e-10: at the default 1e-3 one side can take one more iteration where a residual lies within
  // round-off of its target, and the loads then differ by about 1e-9 of their scale (measured), not round-off.
  SimulationOptions tight;
  tight.pressure_rtol = 1e-10;
  SimulationOptions split = tight;
  split.decomposition = world();
  Simulation whole(c, c.kinematics, BodyMotion{}, plan, tight);
  Simulation part(c, c.kinematics, BodyMotion{}, plan, split);
  const auto [df, f] = load_difference(whole, part, 10, c.insect.wing.length);
  EXPECT_GT(f, 0);
  EXPECT_LE(df, 1e-10 * f);
  if (world()->rank() == 0)
    std::printf("[ rank 0 ] flapping moth, %d x %d x %d cells, 10 steps: part loads differ by %.3g of %.3g N; slab "
                "of %d planes\n",
                plan_grid(plan).shape().nx, plan_grid(plan).shape().ny, plan_grid(plan).shape().nz, df, f,
                part.solver().slab().n);
}

// A field output that rank 0 cannot write (its directory under a file) fails on every rank with OutputError, and the
// ranks go on together: rank 0 takes in the other ranks' planes still on their way (one file per output, and per
// rank as well).
TEST(Decomposition, FieldOutputThatCannotBeWrittenFailsOnEveryRank) {
  const Case c = moth_case();
  const CfdPlan plan = plan_cfd(c, c.kinematics, BodyMotion{});
  SimulationOptions split;
  split.decomposition = world();
  Simulation part(c, c.kinematics, BodyMotion{}, plan, split);
  for (const bool per_rank : {false, true}) {
    FieldOutput out("/dev/null/cannot/fields", 1, FieldPrecision::float64, per_rank);
    EXPECT_THROW(out.write(part), flapstab::OutputError) << "per rank " << per_rank << ", rank " << world()->rank();
    EXPECT_EQ(world()->sum(1.0), double(world()->size()));  // every rank reached here: nothing left hanging
  }
}

// flapstab cfd's run over the ranks (run_cfd with a decomposition): the files in its directory are those of the
// same run in one process, to round-off: forces.csv, the checkpoint, the field file (with the solid mask), the
// surfaces, run.json. The run over the ranks stops after 6 steps and is restarted from its checkpoint for 4 more; the
// one-process run makes its 10 steps at once.
TEST(Decomposition, CfdRunOverRanksWritesTheOneProcessRunsFiles) {
  namespace fs = std::filesystem;
  const Case c = moth_case("fields_per_cycle = 40\nsurfaces_per_cycle = 40\ncheckpoints_per_cycle = 8\n"
                           "field_precision = \"float64\"\n");
  const std::string ranks = shared_path("run"), one = own_path("run_one");
  if (world()->rank() == 0) fs::remove_all(ranks);
  fs::remove_all(one);
  CfdRunOptions o;
  o.pressure_rtol = 1e-10;  // as FlappingInsectLoadsMatchTheSingleRankOnes: round-off needs converged solves
  o.handle_signals = false;
  o.directory = one;
  o.steps = 10;
  const CfdResult r1 = run_cfd(c, c.kinematics, BodyMotion{}, o);
  o.directory = ranks;
  o.decomposition = world();
  o.steps = 6;
  MPI_Barrier(MPI_COMM_WORLD);  // rank 0 has cleared the directory
  const CfdResult a = run_cfd(c, c.kinematics, BodyMotion{}, o);
  EXPECT_EQ(a.steps, 6);
  o.restart = true;
  o.steps = 4;
  const CfdResult r = run_cfd(c, c.kinematics, BodyMotion{}, o);
  EXPECT_EQ(r.start_step, 6);
  EXPECT_EQ(r.steps, 10);
  EXPECT_EQ(r.cells, r1.cells);  // the whole grid's
  EXPECT_EQ(r.status, "stopped");
  if (world()->rank() != 0) return;
  // forces.csv: every row and column
  const int parts = 3;
  ForcesCsv fa("", parts), fb("", parts);
  fa.keep_earlier(ranks + "/forces.csv", 10);
  fb.keep_earlier(one + "/forces.csv", 10);
  double df = 0, f = 0;
  for (std::size_t n = 0; n < 10; ++n)
    for (int i = 0; i < parts; ++i) {
      const flapstab::Wrench wa = fa.earlier()[n].part[i].wrench(), wb = fb.earlier()[n].part[i].wrench();
      df = std::max({df, (wa.force - wb.force).norm(), (wa.moment - wb.moment).norm() / c.insect.wing.length});
      f = std::max(f, wb.force.norm());
    }
  EXPECT_GT(f, 0);
  EXPECT_LE(df, 1e-10 * f) << "forces.csv";
  // the checkpoint of step 10 (the stop's), the whole grid's
  const Shape whole = plan_grid(r1.plan).shape();
  const SimulationState sa = read_state(CheckpointReader(ranks + "/checkpoints/checkpoint_000000010.h5"), whole);
  const SimulationState sb = read_state(CheckpointReader(one + "/checkpoints/checkpoint_000000010.h5"), whole);
  const Slab all{0, whole.nz};
  double du = 0, scale = 0;
  for (int d = 0; d < 3; ++d) {
    const Difference e = compare(sa.u[d], sb.u[d], all);
    du = std::max(du, e.max);
    scale = std::max(scale, e.scale);
  }
  EXPECT_LE(du, 1e-10 * scale) << "checkpoint velocity";
  EXPECT_EQ(sa.step, 10);
  EXPECT_EQ(CheckpointReader(ranks + "/checkpoints/checkpoint_000000010.h5").header().values.at("ranks"),
            world()->size());
  // the last field file (step 10) and the solid mask in it; the surfaces' files
  for (const char* name : {"velocity", "pressure", "solid"}) {
    const StoredField x = read_field(ranks + "/fields/fields_000010.h5", name),
                      y = read_field(one + "/fields/fields_000010.h5", name);
    ASSERT_EQ(x.values.size(), y.values.size()) << name;
    double diff = 0, big = 0;
    for (std::size_t n = 0; n < x.values.size(); ++n) {
      diff = std::max(diff, std::abs(x.values[n] - y.values[n]));
      big = std::max(big, std::abs(y.values[n]));
    }
    EXPECT_GT(big, 0) << name;
    EXPECT_LE(diff, 1e-9 * big) << name;
  }
  auto listing = [](const std::string& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  };
  EXPECT_EQ(listing(ranks + "/surfaces"), listing(one + "/surfaces"));
  EXPECT_EQ(listing(ranks + "/fields"), listing(one + "/fields"));
  std::printf("[ rank 0 ] flapstab cfd's run over %d ranks (6 steps, restart, 4 steps) against one process: "
              "forces.csv %.3g of %.3g N, checkpoint velocity %.3g of %.3g\n",
              world()->size(), df, f, du, scale);
}

// field_files = "per-rank": each rank writes its own planes (fields_STEP.pRANK.h5) and rank 0 the XDMF over them (a
// spatial collection). The pieces put together along z are the one-process run's field file, every field to 1e-9 of
// its scale (the vorticity and Q criterion too: their central differences at a slab's end planes read the cell
// beyond, which the piece takes from a window one plane wider); the series lists the pieces. The one file that rank 0
// writes from the ranks' planes (field_files = "whole") is the pieces put together, bit for bit.
TEST(Decomposition, PerRankFieldFilesPutTogetherAreTheWholeFile) {
  namespace fs = std::filesystem;
  const std::string keys = "fields_per_cycle = 40\nsurfaces_per_cycle = 0\nfield_precision = \"float64\"\n";
  const Case whole_case = moth_case(keys), piece_case = moth_case(keys + "field_files = \"per-rank\"\n");
  const std::string ranks = shared_path("pieces"), one = own_path("pieces_one");
  if (world()->rank() == 0) fs::remove_all(ranks);
  fs::remove_all(one);
  CfdRunOptions o;
  o.pressure_rtol = 1e-10;
  o.handle_signals = false;
  o.directory = one;
  o.steps = 2;
  run_cfd(whole_case, whole_case.kinematics, BodyMotion{}, o);
  o.directory = ranks;
  o.decomposition = world();
  MPI_Barrier(MPI_COMM_WORLD);
  run_cfd(piece_case, piece_case.kinematics, BodyMotion{}, o);
  // The same run with one file per output: rank 0 writes it, taking each field's planes from the ranks slab by slab.
  const std::string streamed = shared_path("streamed_fields");
  if (world()->rank() == 0) fs::remove_all(streamed);
  MPI_Barrier(MPI_COMM_WORLD);
  o.directory = streamed;
  run_cfd(whole_case, whole_case.kinematics, BodyMotion{}, o);
  if (world()->rank() != 0) return;
  const std::string step = "000002";
  EXPECT_FALSE(fs::exists(ranks + "/fields/fields_" + step + ".h5"));
  EXPECT_EQ(read_axes(streamed + "/fields/fields_" + step + ".h5").z,
            read_axes(one + "/fields/fields_" + step + ".h5").z);
  const RectilinearAxes axes = read_axes(one + "/fields/fields_" + step + ".h5");
  std::vector<double> z{axes.z.front()};
  std::vector<std::string> files;
  for (int r = 0; r < world()->size(); ++r) {
    files.push_back(ranks + "/fields/" + FieldWriter::piece_file_name("fields", 2, r));
    const RectilinearAxes a = read_axes(files.back());
    EXPECT_EQ(a.x, axes.x);
    EXPECT_EQ(a.y, axes.y);
    EXPECT_EQ(a.z.front(), z.back()) << "piece " << r << " starts where the one below ends";
    z.insert(z.end(), a.z.begin() + 1, a.z.end());
  }
  EXPECT_EQ(z, axes.z);
  for (const char* name : {"velocity", "pressure", "vorticity", "q_criterion", "solid"}) {
    const StoredField w = read_field(one + "/fields/fields_" + step + ".h5", name);
    std::vector<double> joined;
    for (const std::string& f : files) {
      const StoredField p = read_field(f, name);
      EXPECT_EQ(p.components, w.components) << name;
      joined.insert(joined.end(), p.values.begin(), p.values.end());  // [z][y][x]: the pieces follow along z
    }
    ASSERT_EQ(joined.size(), w.values.size()) << name;
    // The streamed file: the pieces' values bit for bit (the same run's fields, computed the same way on each rank).
    const StoredField st = read_field(streamed + "/fields/fields_" + step + ".h5", name);
    EXPECT_EQ(st.components, w.components) << name;
    EXPECT_TRUE(st.values == joined) << name << ": the streamed file differs from the pieces put together";
    double diff = 0, big = 0;
    for (std::size_t n = 0; n < joined.size(); ++n) {
      diff = std::max(diff, std::abs(joined[n] - w.values[n]));
      big = std::max(big, std::abs(w.values[n]));
    }
    EXPECT_GT(big, 0) << name;
    EXPECT_LE(diff, 1e-9 * big) << name;
    std::printf("[ rank 0 ] %s from %d pieces against the whole file: %.3g of %.3g\n", name, world()->size(), diff,
                big);
  }
  std::ifstream in(ranks + "/fields/fields.xmf");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string series = ss.str();
  EXPECT_NE(series.find("CollectionType=\"Spatial\""), std::string::npos) << series;
  for (const std::string& f : files)
    EXPECT_NE(series.find(fs::path(f).filename().string() + ":/fields/vorticity"), std::string::npos) << f;
}

// Groups of ranks in one job, each running its own flow over its own ranks (Decomposition::split): with 4 ranks or
// more two groups of 2, else groups of 1. Group 0 runs the flapping test moth with the project's multigrid, group 1
// with hypre (whose grid must then live on the group's communicator, not the job's: on the job's it would wait for
// the other group). Each group's loads equal its own flow's in one process.
TEST(Decomposition, GroupsOfRanksRunTheirOwnFlows) {
  const Decomposition& W = *world();
  const int per_group = W.size() >= 4 && W.size() % 2 == 0 ? 2 : 1;
  const std::shared_ptr<const Decomposition> group = W.split(per_group);
  EXPECT_EQ(group->size(), per_group);
  EXPECT_EQ(group->groups(), W.size() / per_group);
  EXPECT_EQ(group->group(), W.rank() / per_group);
  EXPECT_EQ(group->rank(), W.rank() % per_group);
  EXPECT_THROW(W.split(W.size() + 1), std::invalid_argument);
  const bool hypre = group->group() % 2 == 1;
  if (hypre && !hypre_available()) GTEST_SKIP() << "built without hypre";
  const Case c = moth_case(hypre ? "pressure_solver = \"hypre\"\n" : "");
  const CfdPlan plan = plan_cfd(c, c.kinematics, BodyMotion{});
  SimulationOptions one;
  one.pressure_rtol = 1e-10;
  SimulationOptions split = one;
  split.decomposition = group;
  Simulation alone(c, c.kinematics, BodyMotion{}, plan, one);
  Simulation part(c, c.kinematics, BodyMotion{}, plan, split);
  const auto [df, f] = load_difference(alone, part, 5, c.insect.wing.length);
  EXPECT_GT(f, 0);
  // the multigrid: round-off (as FlappingInsectLoadsMatchTheSingleRankOnes); hypre over 2 ranks against hypre on one:
  // the solves' tolerance 1e-10 (its smoother's planes are cut by the slabs), far above round-off
  EXPECT_LE(df, (hypre ? 1e-8 : 1e-10) * f) << (hypre ? "hypre" : "multigrid");
  if (group->rank() == 0)
    std::printf("[ group %d of %d, %d rank(s), %s ] flapping moth, 5 steps: part loads differ by %.3g of %.3g N\n",
                group->group(), group->groups(), group->size(), hypre ? "hypre" : "multigrid", df, f);
}

TEST(Decomposition, ImmersedBodiesNeedAWalledZAxisAndThickSlabs) {
  struct None : StageHooks {
    void after_predictor(VectorField&, double, double) override {}
    void after_projection(VectorField&, Field&, double) override {}
  } hooks;
  const Grid g(Axis::uniform(0, 1, 8, true), Axis::uniform(0, 1, 8, true), Axis::uniform(0, 1, 16, true));
  Solver s(g, Boundaries::all(BC::periodic), SolverOptions{.nu = 0.1}, world());
  // A walled z axis of 8 cells: slabs of 4 planes on 2 ranks (4, 2, 2 on 3), thinner than the window's 5.
  const Grid thin(Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false));
  Solver t(thin, Boundaries::all(BC::velocity), SolverOptions{.nu = 0.1}, world());
  if (world()->distributed()) {
    EXPECT_THROW(s.attach(&hooks), std::invalid_argument);  // periodic z over ranks
    EXPECT_THROW(t.attach(&hooks), std::invalid_argument);  // slabs thinner than 5 planes
  }
  // A walled z axis of 40 cells (20 or 14 planes per rank) takes them.
  Solver w(walled_grid(24, 16, 40), Boundaries::all(BC::velocity), SolverOptions{.nu = 0.1}, world());
  EXPECT_NO_THROW(w.attach(&hooks));
}

}  // namespace

int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  ::testing::InitGoogleTest(&argc, argv);
  const int failed = RUN_ALL_TESTS();  // every rank prints its own results; any rank's failure fails the run
  int any = failed != 0;
  MPI_Allreduce(MPI_IN_PLACE, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return any;
}
