// Benchmarks of stability/delayed_feedback: a 50 x 50 (gain, latency) stability map of a hover-like 5-state
// system with delayed rate and attitude feedback (target: < 5 s per map), one root computation, a best-gain
// search, and delayed Floquet monodromies of the sizes the header quotes.
// Run: cmake -S . -B build -DFLAPSTAB_BUILD_BENCH=ON && cmake --build build --target bench_delayed_feedback &&
//      ./build/bench/bench_delayed_feedback
#include <benchmark/benchmark.h>
#include <cmath>
#include "core/types.hpp"
#include "stability/delayed_feedback.hpp"

namespace {

using namespace flapstab;

// States [u (m/s), w (m/s), q (rad/s), theta (rad), delta (rad)]: a longitudinal hover matrix with speed
// damping X_u, pitch damping M_q and the speed-pitch coupling M_u > 0 that makes hover's oscillatory pair
// unstable (here 0.39 +- 5.76 i 1/s; the pattern of Sun & Xiong 2005, J Exp Biol 208:447; illustrative
// numbers, not one insect), and a first-order actuator delta' = (delta_c - delta) / T_a with moment M_delta.
// Feedback delta_c = -gain (k_q q(t - tau) + k_theta theta(t - 1.5 tau)): rate sensed after the latency tau,
// attitude (visual) 1.5 tau, so B_1 and B_2 are rank one and the collocation carries two history components.
DelaySystem hover_with_feedback(double gain, double latency) {
  constexpr double Ta = 0.02, kq = 1.0, ktheta = 3.0;
  Eigen::MatrixXd A(5, 5);
  A << -3.0, 0, 0, -9.81, 4.9,
       0, -4.0, 0, 0, 0,
       40.0, 0, -8.0, 0, 200.0,
       0, 0, 1, 0, 0,
       0, 0, 0, 0, -1 / Ta;
  Eigen::MatrixXd B1 = Eigen::MatrixXd::Zero(5, 5), B2 = Eigen::MatrixXd::Zero(5, 5);
  B1(4, 2) = -gain * kq / Ta;
  B2(4, 3) = -gain * ktheta / Ta;
  return DelaySystem{A, {{B1, latency}, {B2, 1.5 * latency}}};
}

std::vector<double> linspace(double a, double b, int n) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(a + (b - a) * i / (n - 1));
  return v;
}

// Gains 0..0.4 rad/(rad/s), latencies 0..60 ms: the map's corner check, then 2 500 points at the accepted N.
void BM_StabilityMap50x50(benchmark::State& state) {
  const auto gains = linspace(0.0, 0.4, 50), latencies = linspace(0.0, 0.06, 50);
  double stable = 0;
  int nodes = 0;
  for (auto _ : state) {
    const StabilityMap map = stability_map(hover_with_feedback, gains, latencies);
    stable = double((map.abscissa.array() < 0).count()) / double(map.abscissa.size());
    nodes = map.nodes;
  }
  state.counters["stable_fraction"] = stable;
  state.counters["nodes"] = nodes;
  state.counters["per_point"] =
      benchmark::Counter(2500, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_StabilityMap50x50)->Unit(benchmark::kMillisecond);

// One rightmost_roots call at the map's hardest corner (gain 0.4, latency 60 ms): with the check off (the map's
// per-point cost; 45 x 45 collocation matrix) and on (N = 20 against 30).
void BM_RightmostRoots(benchmark::State& state) {
  DelayRootsOptions o;
  o.check_convergence = state.range(0) != 0;
  const DelaySystem s = hover_with_feedback(0.4, 0.06);
  for (auto _ : state) benchmark::DoNotOptimize(rightmost_roots(s, o).spectral_abscissa());
}
BENCHMARK(BM_RightmostRoots)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// The gain with the largest delay margin over [0.02, 0.4] (latencies up to 0.2 s): 17 + about 25 delay margins.
void BM_BestGain(benchmark::State& state) {
  CriticalLatency c;
  for (auto _ : state) c = best_gain(hover_with_feedback, 0.02, 0.4, 0.2);
  state.counters["gain"] = c.gain;
  state.counters["latency_ms"] = 1e3 * c.latency;
}
BENCHMARK(BM_BestGain)->Unit(benchmark::kMillisecond);

// A periodic 4-state system (the hover matrix above without the actuator, A(t) = A0 (1 + 0.3 cos(2 pi t / T)),
// T = 40 ms) with delayed feedback tau = 3 T, 80 steps per period, one monodromy and its eigenvalues: rank-one
// feedback (n + r M = 4 + 1 x 241 = 245) and a full-rank delayed term (4 + 4 x 241 = 968).
void BM_DelayedFloquet(benchmark::State& state) {
  const bool full_rank = state.range(0) != 0;
  const Eigen::MatrixXd A0 = hover_with_feedback(0, 0).A.topLeftCorner(4, 4);
  const double T = 0.04;
  PeriodicDelaySystem p;
  p.period = T;
  p.n = 4;
  p.A = [&](double t) -> Eigen::MatrixXd { return A0 * (1 + 0.3 * std::cos(2 * pi * t / T)); };
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(4, 4);
  if (full_rank) {
    B = -0.5 * Eigen::MatrixXd::Identity(4, 4);
  } else {
    B(2, 2) = -4.0;
    B(2, 3) = -12.0;
  }
  p.B = {[&](double) -> Eigen::MatrixXd { return B; }};
  p.tau = {3 * T};
  DelayFloquetOptions o;
  o.check_convergence = false;
  DelayFloquet f;
  for (auto _ : state) f = delayed_floquet(p, o);
  state.counters["size"] = double(f.size);
  state.counters["rho"] = f.spectral_radius();
}
BENCHMARK(BM_DelayedFloquet)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
