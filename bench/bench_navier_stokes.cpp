// Benchmarks of the Navier-Stokes core (no bodies): cost per cell per time step of the 3D Taylor-Green vortex in a
// periodic box, and of one pressure-Poisson iteration, FP64, on 1 and 2 OpenMP threads, with the memory traffic of
// the kernels per cell and the bandwidth that traffic implies, against a STREAM-type triad measured in the same process
// (bench/step_timing.hpp). Figure of merit as WaterLily.jl reports it (its benchmark timings,
// github.com/WaterLily-jl/WaterLily.jl): wall time per step / cells.
// Run: cmake -S . -B build -DFLAPSTAB_BUILD_BENCH=ON && cmake --build build --target bench_navier_stokes &&
//      ./build/bench/bench_navier_stokes
#include <benchmark/benchmark.h>
#include <omp.h>
#include <chrono>
#include <cmath>
#include "bench/step_timing.hpp"
#include "cfd/navier_stokes/multigrid.hpp"
#include "cfd/navier_stokes/solver.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::pi;
using flapstab::Vec3;

// 3D Taylor-Green vortex (Brachet et al. 1983), Re = 1600 on the box scale: u = sin x cos y cos z,
// v = -cos x sin y cos z, w = 0 in [0, 2 pi]^3; adaptive step at CFL 1.
Solver taylor_green(int n) {
  const Axis a = Axis::uniform(0, 2 * pi, n, true);
  SolverOptions opt;
  opt.nu = 1.0 / 1600;
  opt.cfl = 1.0;
  Solver s(Grid(a, a, a), Boundaries::all(BC::periodic), opt);
  s.initialise([](double x, double y, double z) {
    return Vec3(std::sin(x) * std::cos(y) * std::cos(z), -std::cos(x) * std::sin(y) * std::cos(z), 0.0);
  });
  return s;
}

void BM_TaylorGreenStep(benchmark::State& state) {
  const int n = int(state.range(0)), threads = int(state.range(1));
  omp_set_num_threads(threads);
  Solver s = taylor_green(n);
  for (int k = 0; k < 10; ++k) s.step();  // leave the start-up (no initial guess yet, pressure adjusting)
  flapstab::bench::time_steps(state, s);
  state.counters["memory_MB"] = double(s.bytes()) / 1e6;
}
BENCHMARK(BM_TaylorGreenStep)
    ->Args({128, 1})
    ->Args({128, 2})
    ->Args({64, 1})
    ->Args({64, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(5);

// One flexible-CG iteration (one V(2,2) cycle plus the Krylov vectors) on a periodic box; with a third argument
// 1, one plain multigrid iteration (the V-cycle plus the fused x += z, r -= L z pass).
void BM_PoissonIteration(benchmark::State& state) {
  const int n = int(state.range(0)), threads = int(state.range(1));
  const bool plain = state.range(2) != 0;
  omp_set_num_threads(threads);
  const Axis a = Axis::uniform(0, 1, n, true);
  const Grid g(a, a, a);
  Poisson P(g, Boundaries::all(BC::periodic).pressure());
  Field x(g.shape()), b(g.shape()), b0(g.shape());
  for (int k = 1; k <= n; ++k)
    for (int j = 1; j <= n; ++j)
      for (int i = 1; i <= n; ++i) b0(i, j, k) = std::sin(2 * pi * (i + 0.5) / n) * std::cos(2 * pi * (j * j + k) / n);
  PoissonOptions opt;
  opt.rtol = 0;
  opt.max_cycles = 4;
  opt.stationary_factor = plain ? 1.0 : 0.0;  // plain: never hand over (each cycle reduces the residual)
  double seconds = 0;
  std::int64_t its = 0;
  for (auto _ : state) {
    b = b0;
    const auto t0 = std::chrono::steady_clock::now();
    its += P.solve(x, b, opt).cycles;
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  const double cells = double(g.cells());
  state.counters["ns_per_cell_iteration"] = seconds * 1e9 / (its * cells);
  const double bytes = flapstab::bench::vcycle_bytes(g) +
                       (plain ? flapstab::bench::plain_update_bytes : flapstab::bench::krylov_bytes);
  state.counters["implied_GB_per_s"] = bytes * double(its) * cells / seconds / 1e9;
}
BENCHMARK(BM_PoissonIteration)->Args({128, 1, 0})->Args({128, 2, 0})->Args({128, 1, 1})->Args({128, 2, 1})->Unit(benchmark::kMillisecond)->UseRealTime();

// One V(2,2) cycle of the single-precision multigrid alone, walled box (Neumann, so the smoothing sweeps are
// fused), n^3 cells: the cost per cell against n shows whether the cycle is bound by memory (the cost grows once
// the finest level's x and b, 8 bytes per cell, no longer fit the caches) or by instructions (flat).
void BM_VCycle(benchmark::State& state) {
  const int n = int(state.range(0)), threads = int(state.range(1));
  omp_set_num_threads(threads);
  const Axis a = Axis::uniform(0, 1, n, false);
  const Grid g(a, a, a);
  Multigrid M(g, Boundaries::all(BC::velocity).pressure());
  Field r(g.shape()), z(g.shape());
  for (int k = 1; k <= n; ++k)
    for (int j = 1; j <= n; ++j)
      for (int i = 1; i <= n; ++i) r(i, j, k) = std::sin(7.0 * i / n) * std::cos(5.0 * (j + k * k) / n);
  double seconds = 0;
  std::int64_t cycles = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    M.vcycle(r, z, 2, 2);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ++cycles;
  }
  const double cells = double(g.cells()), bytes = flapstab::bench::vcycle_bytes(g);
  state.counters["ns_per_cell_cycle"] = seconds * 1e9 / (double(cycles) * cells);
  state.counters["bytes_per_cell_cycle"] = bytes;
  state.counters["implied_GB_per_s"] = bytes * double(cycles) * cells / seconds / 1e9;
}
BENCHMARK(BM_VCycle)
    ->ArgsProduct({{32, 64, 96, 128, 192}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(2);

}  // namespace
