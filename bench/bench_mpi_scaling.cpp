// Strong scaling of the decomposed Navier-Stokes step: a three-dimensional Taylor-Green vortex (Re = 1600 on the
// vortex scale, the usual transition case) in a periodic box of n^3 cells, the same steps on however many ranks
// mpiexec starts. Rank 0 prints the whole-problem cost per cell and step, the pressure iterations per step and what
// each rank communicated per step (exchanges, bytes, reductions), the figures of the cost model in
// docs/theory/scale-out.md. Run, e.g. (bench/mpi_scaling.sh does all three):
//   OMP_NUM_THREADS=2 mpiexec -n 1 ./build/bench/bench_mpi_scaling 96 20
//   OMP_NUM_THREADS=1 mpiexec -n 2 --bind-to core ./build/bench/bench_mpi_scaling 96 20
// Arguments: n (cells per side, default 96), timed steps (default 20); 5 untimed steps come first.
#include <mpi.h>
#include <omp.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include "cfd/navier_stokes/solver.hpp"

using namespace flapstab::ns;
using flapstab::Vec3;

int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  const int n = argc > 1 ? std::atoi(argv[1]) : 96, steps = argc > 2 ? std::atoi(argv[2]) : 20;
  const auto dec = Decomposition::world();
  const double L = 2 * M_PI;
  const Grid g(Axis::uniform(0, L, n, true), Axis::uniform(0, L, n, true), Axis::uniform(0, L, n, true));
  SolverOptions opt;
  opt.nu = 1.0 / 1600;
  opt.dt = 0.5 * L / n;  // CFL about 0.5 * 3 at the vortex's speed 1
  opt.poisson.rtol = 1e-6;
  Solver s(g, Boundaries::all(BC::periodic), opt, dec);
  s.initialise([](double x, double y, double z) {
    return Vec3(std::sin(x) * std::cos(y) * std::cos(z), -std::cos(x) * std::sin(y) * std::cos(z), 0.0);
  });
  for (int k = 0; k < 5; ++k) s.step();
  const Decomposition::Traffic before = dec->traffic();
  long cycles = 0;
  MPI_Barrier(MPI_COMM_WORLD);
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) {
    s.step();
    for (const PoissonStats& p : s.poisson_stats()) cycles += p.cycles;
  }
  MPI_Barrier(MPI_COMM_WORLD);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Decomposition::Traffic& after = dec->traffic();
  const double energy = s.kinetic_energy();
  if (dec->rank() == 0)
    std::printf("ranks %d threads %d cells %d^3 steps %d: %.1f ns per cell step (whole grid), %.2f s, %.2f pressure "
                "iterations per step, kinetic energy %.12e; rank 0 per step: %.1f exchanges, %.3g bytes sent, "
                "%.1f gathers, %.1f reductions; slab of %d planes\n",
                dec->size(), omp_get_max_threads(), n, steps, seconds * 1e9 / (double(steps) * g.cells()), seconds,
                double(cycles) / steps, energy, double(after.exchanges - before.exchanges) / steps,
                (after.bytes - before.bytes) / steps, double(after.gathers - before.gathers) / steps,
                double(after.reductions - before.reductions) / steps, s.slab().n);
  MPI_Finalize();
  return 0;
}
