// Timing of solver steps for the Navier-Stokes benchmarks, and the memory traffic model behind the bandwidth figure.
#pragma once
#include <benchmark/benchmark.h>
#include <omp.h>
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include "cfd/navier_stokes/solver.hpp"

namespace flapstab::bench {

// Bytes each kernel moves per cell (write-allocate not counted, as in STREAM). Per RK3 stage: predictor (read u, v,
// w, p, N_prev; write N_prev, u*) 104; divergence (read u*, write b) 32; mean and max of b 8; residual of the
// initial guess (read phi, b; write b) 24; projection (read u*, phi, p; write u, p) 72 -> 240. Per step: the
// CFL pass (read u, v, w) 24. Per Poisson iteration, finest level, the single-precision V(2,2) cycle: with walled
// z faces the two pre-smoothing sweeps are one pass (read r in double, write b and x: 16) and so are the two
// post-smoothing sweeps (read x, b; write x, and z in double: 20); restriction reads x, b: 8; prolongation reads
// and writes x: 8; coarse levels +1/7 -> 59. With periodic z the sweeps run one at a time: the first from zero
// 16, three reading x, b and writing x 3 x 12, the last colour also writes z 8, transfers 16; +1/7 -> 87 (the
// smoother divides by the diagonal: no stored inverse is read). Conjugate-gradient vectors (<z, q>: 16;
// p = z + beta p: 24; q = L p with <p, q>, <p, r>: 24; x and r update: 48) 112; the first iteration of a solve
// has no <z, q> and no p update (-40). A plain multigrid iteration (PoissonOptions::stationary_factor) has
// instead one pass x += z, r -= L z (read x, r, z; write x, r) 40.
constexpr double stage_bytes = 240, step_bytes = 24, vcycle_bytes_fused = 59, vcycle_bytes_single = 87,
                 krylov_bytes = 112, first_iteration_saving = 40, plain_update_bytes = 40;
inline double vcycle_bytes(const ns::Grid& g) { return g.axis[2].periodic ? vcycle_bytes_single : vcycle_bytes_fused; }

// The memory bandwidth of this machine at the current OpenMP thread count, measured in this process: a STREAM-type
// triad a = b + s c over three arrays of 2^24 doubles (128 MiB each, beyond the caches), 24 bytes per element (the
// write-allocate of a not counted, as in STREAM and the traffic model above), best of 5 passes after one untimed
// pass; GB/s (1e9 bytes). Measured once per thread count and kept.
inline double triad_GB_per_s() {
  static std::map<int, double> measured;
  const int threads = omp_get_max_threads();
  if (const auto it = measured.find(threads); it != measured.end()) return it->second;
  const std::ptrdiff_t n = std::ptrdiff_t(1) << 24;
  std::unique_ptr<double[]> a(new double[std::size_t(n)]), b(new double[std::size_t(n)]), c(new double[std::size_t(n)]);
  double* pa = a.get();
  double* pb = b.get();
  double* pc = c.get();
#pragma omp parallel for schedule(static)  // first touch by the threads that use them
  for (std::ptrdiff_t i = 0; i < n; ++i) pa[i] = 0, pb[i] = 1, pc[i] = 2;
  double best = 0;
  for (int pass = 0; pass < 6; ++pass) {
    const double s = 0.5 + pass;
    const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) pa[i] = pb[i] + s * pc[i];
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    benchmark::DoNotOptimize(pa[n / 2]);
    if (pass > 0) best = std::max(best, 24.0 * double(n) / seconds / 1e9);
  }
  measured[threads] = best;
  return best;
}

// Times one solver step per benchmark iteration and sets ns_per_cell_step, poisson_iterations_per_step (of which
// plain_iterations_per_step),
// bytes_per_cell_step (body-free kernels' traffic) and implied_GB_per_s, and against the triad measured at the same
// thread count in this process (triad_GB_per_s): bound_ns_per_cell_step, the time that traffic takes at that
// bandwidth, and ratio_to_bound = ns_per_cell_step / bound_ns_per_cell_step.
inline void time_steps(benchmark::State& state, ns::Solver& s) {
  const double triad = triad_GB_per_s();
  const double cells = double(s.grid().cells());
  double seconds = 0, iterations = 0, plain = 0, krylov_starts = 0;
  std::int64_t steps = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    s.step();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ++steps;
    for (const auto& st : s.poisson_stats()) {
      iterations += st.cycles;
      plain += st.stationary;
      krylov_starts += st.cycles > st.stationary ? 1 : 0;
    }
  }
  const double per_step = iterations / double(steps), plain_per_step = plain / double(steps);
  const double mg = vcycle_bytes(s.grid());
  const double bytes = 3 * stage_bytes + step_bytes + plain_per_step * (mg + plain_update_bytes) +
                       (per_step - plain_per_step) * (mg + krylov_bytes) - krylov_starts / double(steps) * first_iteration_saving;
  state.counters["ns_per_cell_step"] = seconds * 1e9 / (double(steps) * cells);
  state.counters["poisson_iterations_per_step"] = per_step;
  state.counters["plain_iterations_per_step"] = plain_per_step;
  state.counters["bytes_per_cell_step"] = bytes;
  state.counters["implied_GB_per_s"] = bytes * double(steps) * cells / seconds / 1e9;
  state.counters["triad_GB_per_s"] = triad;
  state.counters["bound_ns_per_cell_step"] = bytes / triad;
  state.counters["ratio_to_bound"] = seconds * 1e9 / (double(steps) * cells) / (bytes / triad);
}

}  // namespace flapstab::bench
