// Benchmark of the Navier-Stokes solver with a flapping insect immersed: the default hawkmoth (body and two membrane
// wings, prescribed hover kinematics) in quiescent air at Re = 1000, on a stretched grid of about 2.2 million cells
// (fine box around the swept volume, geometric stretching to the far field). FP64, 1 and 2 OpenMP threads. Cost
// in ns per cell per step as WaterLily.jl reports it (its benchmark timings,
// github.com/WaterLily-jl/WaterLily.jl), the immersed boundary's share of it, and the
// memory traffic of the body-free kernels per cell (bench_navier_stokes.cpp) with the bandwidth it implies, and the
// bound that traffic sets at the bandwidth of a STREAM-type triad measured in the same process at the same thread
// count (bench/step_timing.hpp: triad_GB_per_s, bound_ns_per_cell_step, ratio_to_bound).
// Run: cmake -S . -B build -DFLAPSTAB_BUILD_BENCH=ON && cmake --build build --target bench_immersed &&
//      ./build/bench/bench_immersed
#include <benchmark/benchmark.h>
#include <omp.h>
#include <chrono>
#include <cmath>
#include <memory>
#include "bench/flapping_case.hpp"
#include "bench/step_timing.hpp"
#include "cfd/navier_stokes/immersed.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::Vec3;
using flapstab::bench::hawkmoth;

// Arguments: threads; Poisson variant 0: the solver's default, 1: flexible CG from the first iteration (the
// solver before plain multigrid iterations were added), for an A/B on the same machine state; 2: V(1,1) cycles
// instead of V(2,2) (the fused smoothing passes move the same bytes with half the arithmetic: a lower
// ratio_to_bound but more iterations and a slower step, docs/validation.md).
void BM_FlappingHawkmothStep(benchmark::State& state) {
  const int threads = int(state.range(0));
  omp_set_num_threads(threads);
  PoissonOptions po = SolverOptions{}.poisson;
  if (state.range(1) == 1) po.stationary_factor = 0;
  if (state.range(1) == 2) po.pre_sweeps = po.post_sweeps = 1;
  auto f = hawkmoth(po);
  Solver& s = *f->solver;
  for (int k = 0; k < 10; ++k) s.step();  // leave the impulsive start
  flapstab::bench::time_steps(state, s);
  state.counters["cells"] = double(s.grid().cells());
  state.counters["forced_faces"] = double(f->ib->solid_faces() + f->ib->band_faces());
  state.counters["memory_MB"] = double(s.bytes() + f->ib->bytes()) / 1e6;
}
// A fixed number of steps (the same wingbeat phases in every run, so that runs and variants compare the same
// work: the Poisson iterations per step vary along the wingbeat).
BENCHMARK(BM_FlappingHawkmothStep)
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Args({2, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(48);

// The immersed boundary's own cost: one stage's classification and forcing at a new time (the predictor's
// velocity is whatever the solver holds), per cell of the grid.
void BM_FlappingHawkmothForcing(benchmark::State& state) {
  const int threads = int(state.range(0));
  omp_set_num_threads(threads);
  auto f = hawkmoth();
  VectorField u = f->solver->velocity();
  const double T = f->c.kinematics.period(), cells = double(f->solver->grid().cells());
  double t = 0, seconds = 0;
  std::int64_t n = 0;
  for (auto _ : state) {
    t += T / 400;
    const auto t0 = std::chrono::steady_clock::now();
    f->ib->after_predictor(u, t, T / 400);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ++n;
  }
  state.counters["ns_per_cell_stage"] = seconds * 1e9 / (n * cells);
}
BENCHMARK(BM_FlappingHawkmothForcing)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
