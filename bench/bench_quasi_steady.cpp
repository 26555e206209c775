// Benchmarks of the quasi-steady path on the default hawkmoth case: one model run (one wingbeat),
// the hover trim, and the 36 cycle-averaged derivatives. Targets (issue 2): trim-hover < 2 s.
#include <benchmark/benchmark.h>
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "trim/trim.hpp"

namespace {

using namespace flapstab;

const Case& hawkmoth() {
  static const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml");
  return c;
}

// One wingbeat: samples_per_cycle instants x 2 wings x blade_elements strips.
void BM_QuasiSteadyRun(benchmark::State& state) {
  const Case& c = hawkmoth();
  const auto model = make_aero_model(c);
  AeroRunOptions opt;
  opt.samples_per_cycle = int(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(model->run(c.insect, c.kinematics, BodyMotion{}, opt).mean());
  state.counters["strip_evaluations_per_s"] =
      benchmark::Counter(double(state.range(0)) * 2 * c.aero.quasi_steady.blade_elements, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_QuasiSteadyRun)->Arg(128)->Arg(512)->Unit(benchmark::kMicrosecond);

void BM_TrimHover(benchmark::State& state) {
  const Case& c = hawkmoth();
  const auto model = make_aero_model(c);
  for (auto _ : state) benchmark::DoNotOptimize(trim_hover(c, *model).converged);
}
BENCHMARK(BM_TrimHover)->Unit(benchmark::kMillisecond);

void BM_CycleAveragedDerivatives(benchmark::State& state) {
  const Case& c = hawkmoth();
  const auto model = make_aero_model(c);
  const TrimResult t = trim_hover(c, *model);
  for (auto _ : state)
    benchmark::DoNotOptimize(cycle_averaged_derivatives(*model, c.insect, t.kinematics, c.fluid, 0.01).table.nd(0, 0));
}
BENCHMARK(BM_CycleAveragedDerivatives)->Unit(benchmark::kMillisecond);

}  // namespace
