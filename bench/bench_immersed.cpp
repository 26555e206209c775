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
#include "bench/step_timing.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "core/case_file.hpp"
#include "core/configuration.hpp"

namespace {

using namespace flapstab::ns;
using flapstab::Vec3;

struct FlappingCase {
  flapstab::Case c;
  std::unique_ptr<flapstab::Configuration> config;
  std::unique_ptr<InsectSurfaces> surfaces;
  std::unique_ptr<Solver> solver;
  std::unique_ptr<ImmersedBoundary> ib;
};

// The hawkmoth at rest in a box: fine spacing c_bar / 16 over the swept volume plus half a chord, stretching 1.06
// to 3 R beyond it on every side.
std::unique_ptr<FlappingCase> hawkmoth(const PoissonOptions& poisson = SolverOptions{}.poisson) {
  auto f = std::make_unique<FlappingCase>();
  f->c = flapstab::load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml");
  f->config = std::make_unique<flapstab::Configuration>(f->c.insect, f->c.kinematics);
  MeshResolution res;
  f->surfaces = std::make_unique<InsectSurfaces>(*f->config, res);
  const double R = f->c.insect.wing.length, cbar = f->c.insect.wing.mean_chord, T = f->c.kinematics.period();
  BoundingBox swept;
  for (int n = 0; n < 32; ++n)
    for (const auto& part : f->surfaces->at(T * n / 32)) {
      const BoundingBox b = part.mesh.bounding_box();
      swept.add(b.lo);
      swept.add(b.hi);
    }
  std::array<Axis, 3> axes{Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false)};
  for (int a = 0; a < 3; ++a) {
    StretchedAxis s;
    s.box_lo = swept.lo[a] - 0.5 * cbar;
    s.box_hi = swept.hi[a] + 0.5 * cbar;
    s.lo = s.box_lo - 3 * R;
    s.hi = s.box_hi + 3 * R;
    s.h = cbar / 16;
    s.max_ratio = 1.06;
    s.multiple_of = 16;
    axes[a] = Axis::stretched(s, false);
  }
  // Re = U c_bar / nu = 1000 with U the mean wingtip speed 2 Phi f R.
  const double U = 2 * f->c.kinematics.stroke_amplitude() * f->c.kinematics.frequency_hz * R;
  SolverOptions opt;
  opt.nu = U * cbar / 1000;
  opt.cfl = 0.8;
  opt.poisson = poisson;
  Boundaries bc = Boundaries::all(BC::velocity);
  bc.face[face(2, 0)].type = BC::outflow;  // the downwash leaves through the bottom
  f->solver = std::make_unique<Solver>(Grid(axes[0], axes[1], axes[2]), bc, opt);
  f->solver->initialise([](double, double, double) { return Vec3::Zero(); });
  ImmersedOptions io;
  io.density = f->c.fluid.density;
  f->ib = std::make_unique<ImmersedBoundary>(f->solver->grid(), io);
  for (int k = 0; k < 3; ++k) {
    const flapstab::Configuration* config = f->config.get();
    f->ib->add_part(f->surfaces->reference()[std::size_t(k)], [config, k](double t) {
      const PartPose p = insect_part_poses(*config, t)[std::size_t(k)];
      return PartState{p.pose, p.motion};
    });
  }
  f->ib->attach(*f->solver);
  return f;
}

// Arguments: threads; Poisson variant 0: the solver's default, 1: flexible CG from the first iteration (the
// solver before plain multigrid iterations were added), for an A/B on the same machine state.
void BM_FlappingHawkmothStep(benchmark::State& state) {
  const int threads = int(state.range(0));
  omp_set_num_threads(threads);
  PoissonOptions po = SolverOptions{}.poisson;
  if (state.range(1) == 1) po.stationary_factor = 0;
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
BENCHMARK(BM_FlappingHawkmothStep)->Args({1, 0})->Args({2, 0})->Args({1, 1})->Args({2, 1})->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(48);

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
