// Benchmark of free flight coupled to the Navier-Stokes solver (flight/cfd_flight.hpp): the coupled step against the
// prescribed-motion step on the same grid (the target: at most 1.2 x). The shipped CFD hawkmoth
// (data/cases/hawkmoth_cfd.toml, 8 cells per mean chord, 400 steps per wingbeat), started from rest; after 10 warm-up
// steps each, the two simulations advance in turn (A, B, A, B, ...) so that the machine's load falls on both alike.
// Counters: ns per cell step of each, their ratio (coupled / prescribed), and the extra seconds per coupled step.
#include <benchmark/benchmark.h>
#include <chrono>
#include <omp.h>
#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "flight/cfd_flight.hpp"

namespace {

using namespace flapstab;

void BM_CoupledAgainstPrescribedHawkmothStep(benchmark::State& state) {
  Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/hawkmoth_cfd.toml");
  c.aero.cfd.threads = int(state.range(0));
  const ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  const ns::CfdModel unused(c, nullptr);
  const FlightDynamics dyn(unused, c.insect, c.kinematics, {}, DofSet::longitudinal, std::nullopt, false, c.path);
  ns::Simulation prescribed(c, c.kinematics, BodyMotion{}, plan);
  CfdFlight coupled(c, dyn, plan);
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(7) = 0.35;  // q, rad/s (20 deg/s)
  coupled.start(nullptr, x0);
  omp_set_num_threads(int(state.range(0)));
  for (int k = 0; k < 10; ++k) prescribed.advance(), coupled.advance();
  double ta = 0, tb = 0;
  long n = 0;
  using clock = std::chrono::steady_clock;
  for (auto _ : state) {
    auto t0 = clock::now();
    prescribed.advance();
    ta += std::chrono::duration<double>(clock::now() - t0).count();
    t0 = clock::now();
    coupled.advance();
    tb += std::chrono::duration<double>(clock::now() - t0).count();
    ++n;
  }
  const double cells = double(prescribed.cells());
  state.counters["cells"] = cells;
  state.counters["prescribed_ns_per_cell_step"] = ta * 1e9 / (double(n) * cells);
  state.counters["coupled_ns_per_cell_step"] = tb * 1e9 / (double(n) * cells);
  state.counters["coupled_over_prescribed"] = tb / ta;
  state.counters["extra_ms_per_step"] = (tb - ta) * 1e3 / double(n);
}
BENCHMARK(BM_CoupledAgainstPrescribedHawkmothStep)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(40);

}  // namespace
