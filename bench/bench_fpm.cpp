// Benchmark of force partitioning in a CFD run: the hawkmoth of data/examples/fpm_hawkmoth_cfd.toml (Re 1000, 8 cells
// per mean chord, 491 520 cells, 400 steps per wingbeat) stepped 80 timed steps from the same state (20 steps from
// rest, then 20 untimed steps with the observer: two samples, so that the timed ones start from potentials
// extrapolated from the last two as in a run), without and with the FPM observer at 40 samples per wingbeat (8 samples),
// default settings (F_x, F_z of body and both wings: 6 potentials per sample; argument 1) and the lift only (F_z, 3
// potentials; argument 2). The target: the run with FPM at most 1.5 x the run without. Reported: ms per 80
// steps of each; the FPM benchmarks print the ratios to the first's wall time (cost_ratio) and process CPU time
// (cpu_ratio, steadier on a shared machine) as counters, and the mean iterations per potential over all ten samples.
// Run: cmake -S . -B build -DFLAPSTAB_BUILD_BENCH=ON && cmake --build build --target bench_fpm &&
//      OMP_NUM_THREADS=1 ./build/bench/bench_fpm
#include <benchmark/benchmark.h>
#include <chrono>
#include <ctime>
#include <memory>
#include <optional>
#include "cfd/fpm/observer.hpp"
#include "cfd/fpm/partition.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "cfd/navier_stokes/simulation.hpp"
#include "core/case_file.hpp"

namespace {

using namespace flapstab;

struct Moth {
  Case c;
  ns::CfdPlan plan;
  std::unique_ptr<ns::Simulation> sim;
  ns::SimulationState start;
};

Moth& moth() {
  static Moth m = [] {
    Moth x;
    x.c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/examples/fpm_hawkmoth_cfd.toml");
    x.plan = ns::plan_cfd(x.c, x.c.kinematics, BodyMotion{});
    x.sim = std::make_unique<ns::Simulation>(x.c, x.c.kinematics, BodyMotion{}, x.plan);
    for (int n = 0; n < 20; ++n) x.sim->advance();
    x.start = x.sim->state();
    return x;
  }();
  return m;
}

double without_ms = 0, without_cpu = 0;

void BM_HawkmothSteps(benchmark::State& state) {
  const bool with_fpm = state.range(0) >= 1;
  flapstab::FpmSettings settings = moth().c.aero.cfd.fpm;
  if (state.range(0) == 2) settings.components = {"Fz"};  // the lift only: 3 potentials per sample
  Moth& m = moth();
  double total = 0, cpu = 0;
  long n = 0;
  for (auto _ : state) {
    m.sim->restore(m.start);
    std::optional<fpm::FpmObserver> ob;
    if (with_fpm) ob.emplace(*m.sim, settings, std::string());
    for (int k = 0; k < 20; ++k) {  // untimed: two samples, so the timed ones start from extrapolated potentials
      const ns::StepReport r = m.sim->advance();
      if (ob) ob->on_step(*m.sim, r);
    }
    const long untimed = ob ? long(ob->samples()) : 0;
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    for (int k = 0; k < 80; ++k) {
      const ns::StepReport r = m.sim->advance();
      if (ob) ob->on_step(*m.sim, r);
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(s);
    total += s, ++n;
    cpu += double(std::clock() - c0) / CLOCKS_PER_SEC;
    if (ob) state.counters["samples"] = double(long(ob->samples()) - untimed);  // timed samples
    if (ob) state.counters["potential_iterations"] = ob->mean_potential_iterations();
  }
  const double ms = 1e3 * total / double(n);
  if (!with_fpm) without_ms = ms, without_cpu = cpu / double(n);
  else if (without_ms > 0) {
    state.counters["cost_ratio"] = ms / without_ms;
    state.counters["cpu_ratio"] = cpu / double(n) / without_cpu;
  }
}
// The force partition's own work at one sample, from zero potentials: the cut-cell geometry and the six potentials
// of the default settings (F_x, F_z of body and both wings) at the benchmark's state, a fresh ForcePartition per
// iteration. Steadier than the run above for comparing solver changes; mean iterations per potential as a counter.
void BM_PotentialsFromZero(benchmark::State& state) {
  Moth& m = moth();
  m.sim->restore(m.start);
  fpm::FpmOptions opt;
  opt.rtol = m.c.aero.cfd.fpm.tolerance;
  opt.components = {0, 2};
  const std::vector<ns::PartState> states = m.sim->part_states();
  double iterations = 0;
  long solves = 0;
  for (auto _ : state) {
    fpm::ForcePartition fp(m.sim->grid(), opt);
    for (const auto& r : fp.update(*m.sim->immersed(), states)) iterations += r.stats.iterations, ++solves;
  }
  state.counters["potential_iterations"] = iterations / double(std::max(1L, solves));
}
BENCHMARK(BM_PotentialsFromZero)->Unit(benchmark::kMillisecond)->Iterations(6);

BENCHMARK(BM_HawkmothSteps)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(3);

}  // namespace
