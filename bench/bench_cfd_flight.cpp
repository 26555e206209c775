// Benchmark of free flight coupled to the Navier-Stokes solver (flight/cfd_flight.hpp): the coupled step against the
// prescribed-motion step on the same grid (the target: at most 1.2 x). The shipped CFD hawkmoth
// (data/cases/hawkmoth_cfd.toml, 8 cells per mean chord, 400 steps per wingbeat), started from rest; after 10 warm-up
// steps each, the two simulations advance in turn (A, B, A, B, ...) so that the machine's load falls on both alike.
// Counters: ns per cell step of each, their ratio (coupled / prescribed), and the extra seconds per coupled step.
// The closed-loop variant flies under a pitch controller on the stroke plane whose rate term has no latency, so
// that the commanded kinematics (a Configuration per evaluation) are built at every stage of every step.
#include <benchmark/benchmark.h>
#include <algorithm>
#include <chrono>
#include <omp.h>
#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "flight/cfd_flight.hpp"
#include "flight/controller.hpp"

namespace {

using namespace flapstab;

void coupled_against_prescribed(benchmark::State& state, bool closed_loop) {
  Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/hawkmoth_cfd.toml");
  c.aero.cfd.threads = int(state.range(0));
  // The commanded stroke plane sweeps the wings beyond the trimmed kinematics' swept volume: room in the fine box,
  // twice what the sweep takes, so that the fine box is not re-planned (at half the room) in the timed steps.
  if (closed_loop) c.aero.cfd.fine_margin_R = std::max(c.aero.cfd.fine_margin_R, 0.4);
  const ns::CfdPlan plan = ns::plan_cfd(c, c.kinematics, BodyMotion{});
  const ns::CfdModel unused(c, nullptr);
  std::vector<TrimParameterSpec> actuators;
  if (closed_loop) actuators.push_back(unbounded_parameter("stroke_plane_deg"));
  const FlightDynamics dyn(unused, c.insect, c.kinematics, actuators, DofSet::longitudinal, std::nullopt, false,
                           c.path);
  ns::Simulation prescribed(c, c.kinematics, BodyMotion{}, plan);
  CfdFlight coupled(c, dyn, plan);
  BodyStateVector x0 = BodyStateVector::Zero();
  x0(7) = 0.35;  // q, rad/s (20 deg/s)
  if (closed_loop) {
    PitchControllerSettings p;
    p.pitch_gain = 0.5;
    p.rate_gain_s = 0.05;
    p.pitch_latency_s = 0.041;
    p.rate_latency_s = 0;
    coupled.set_controller(pitch_controller(p, parameter_value(c.kinematics, "stroke_plane_deg")),
                           [](double) { return BodyStateVector::Zero().eval(); });
  }
  coupled.set_replanning(true);  // as flapstab fly flies: the fine box's room checked after every step
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
  // A re-plan of the coupled flight's fine box (a one-off of a new solver and the flow carried over) in the timed
  // steps would weigh on its mean: counted, with the coupled grid's cells at the end.
  state.counters["replans"] = double(coupled.replans().size());
  state.counters["coupled_cells"] = double(coupled.simulation().cells());
}

void BM_CoupledAgainstPrescribedHawkmothStep(benchmark::State& state) { coupled_against_prescribed(state, false); }
void BM_ClosedLoopAgainstPrescribedHawkmothStep(benchmark::State& state) { coupled_against_prescribed(state, true); }
BENCHMARK(BM_CoupledAgainstPrescribedHawkmothStep)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(40);
BENCHMARK(BM_ClosedLoopAgainstPrescribedHawkmothStep)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(40);

}  // namespace
