// Benchmarks of `flapstab analyze` on the default hawkmoth case by stage: the cyclic trim (CVODES shooting with
// forward sensitivities, from the averaged trim), the whole Floquet study (both trims, derivatives, orbit,
// phase-resolved derivatives, both routes' monodromies) and the whole analyze command (report and figures
// included, written to a temporary directory). Target (issue "The main job in under 1 s"): analyze < 1 s.
#include <benchmark/benchmark.h>
#include <filesystem>
#include "apps/commands.hpp"
#include "apps/floquet_command.hpp"
#include "cfd/aero_factory.hpp"
#include "trim/cyclic.hpp"
#include "trim/trim.hpp"

namespace {

using namespace flapstab;

const Case& hawkmoth() {
  static const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml");
  return c;
}

void BM_CyclicTrimHawkmoth(benchmark::State& state) {
  const Case& c = hawkmoth();
  const auto model = make_aero_model(c);
  const TrimResult averaged = trim_hover(c, *model);
  int integrations = 0;
  for (auto _ : state) {
    const CyclicTrimResult r = cyclic_trim(c, *model, averaged);
    integrations = r.integrations;
    benchmark::DoNotOptimize(r.residual);
  }
  state.counters["integrations"] = integrations;
}
BENCHMARK(BM_CyclicTrimHawkmoth)->Unit(benchmark::kMillisecond);

void BM_FloquetStudyHawkmoth(benchmark::State& state) {
  const Case& c = hawkmoth();
  const auto model = make_aero_model(c);
  for (auto _ : state) benchmark::DoNotOptimize(floquet_study(c, *model).longitudinal.max_multiplier_difference);
}
BENCHMARK(BM_FloquetStudyHawkmoth)->Unit(benchmark::kMillisecond);

void BM_AnalyzeHawkmoth(benchmark::State& state) {
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "flapstab_bench_analyze";
  CommandOptions o;
  o.case_path = std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml";
  o.output_dir = out.string();
  o.quiet = true;
  for (auto _ : state) benchmark::DoNotOptimize(run_analyze(o));
  std::filesystem::remove_all(out);
}
BENCHMARK(BM_AnalyzeHawkmoth)->Unit(benchmark::kMillisecond);

}  // namespace
