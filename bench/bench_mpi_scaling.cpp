// Strong scaling of the decomposed Navier-Stokes step, the same steps on however many ranks mpiexec starts:
//  - a three-dimensional Taylor-Green vortex (Re = 1600 on the vortex scale) in a periodic box of n^3 cells;
//  - `hawkmoth`: the flapping hawkmoth of bench_immersed (bench/flapping_case.hpp, 4.3 M cells, Re = 1000), the
//    immersed boundary on each rank's window.
// Rank 0 prints the whole-problem cost per cell and step, the pressure iterations per step and what each rank
// communicated per step (exchanges, bytes, reductions), the figures of the cost model in docs/theory/scale-out.md,
// each rank's wall time in communication per step, the time the same messages take alone (every rank ready: the
// transfers without the waits), the interconnect's latency and bandwidth (ping-pong) and what they make of the step's
// exchanges, and for the hawkmoth the summed wing and body force. bench/mpi_scaling.sh runs 1 rank with 1 and 2
// threads and 2 ranks, alternated, e.g.
//   OMP_NUM_THREADS=1 mpiexec -n 2 --bind-to none ./build/bench/bench_mpi_scaling 96 20
//   OMP_NUM_THREADS=1 mpiexec -n 2 --bind-to none ./build/bench/bench_mpi_scaling hawkmoth 20
// Arguments: n (cells per side, default 96) or `hawkmoth`, timed steps (default 20); 5 (hawkmoth: 10) untimed
// steps come first.
#include <mpi.h>
#include <omp.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>
#include "bench/flapping_case.hpp"
#include "cfd/navier_stokes/solver.hpp"

using namespace flapstab::ns;
using flapstab::Vec3;

int main(int argc, char** argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  const bool moth = argc > 1 && std::string(argv[1]) == "hawkmoth";
  const int n = argc > 1 && !moth ? std::atoi(argv[1]) : 96, steps = argc > 2 ? std::atoi(argv[2]) : 20;
  const auto dec = Decomposition::world();
  std::unique_ptr<flapstab::bench::FlappingCase> f;
  std::unique_ptr<Solver> box;
  if (moth) {
    f = flapstab::bench::hawkmoth(SolverOptions{}.poisson, dec);
  } else {
    const double L = 2 * M_PI;
    const Grid g(Axis::uniform(0, L, n, true), Axis::uniform(0, L, n, true), Axis::uniform(0, L, n, true));
    SolverOptions opt;
    opt.nu = 1.0 / 1600;
    opt.dt = 0.5 * L / n;  // CFL about 0.5 * 3 at the vortex's speed 1
    opt.poisson.rtol = 1e-6;
    box = std::make_unique<Solver>(g, Boundaries::all(BC::periodic), opt, dec);
    box->initialise([](double x, double y, double z) {
      return Vec3(std::sin(x) * std::cos(y) * std::cos(z), -std::cos(x) * std::sin(y) * std::cos(z), 0.0);
    });
  }
  Solver& s = moth ? *f->solver : *box;
  const Grid& g = s.whole_grid();
  for (int k = 0; k < (moth ? 10 : 5); ++k) s.step();
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
  Vec3 force = Vec3::Zero();
  if (moth)
    for (const PartLoads& l : f->ib->exchange_loads(s, Vec3::Zero())) force += l.force();
  // Every rank's time in communication per step (transfers and waits: a rank that waits for a slower one
  // shows the imbalance).
  std::vector<double> comm(std::size_t(dec->size()));
  const double mine = (after.seconds - before.seconds) / steps;
  MPI_Gather(&mine, 1, MPI_DOUBLE, comm.data(), 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  std::string comm_text;
  for (double c : comm) {
    if (!comm_text.empty()) comm_text += ' ';
    comm_text += std::to_string(int(std::lround(1e3 * c)));
  }
  // The transfers alone: rank 0's exchanges of one step replayed as messages of the step's mean size to a neighbour
  // and back, every rank ready (no waiting for computation): the part of the communication time that moving the
  // bytes costs.
  double transfer = 0;
  if (dec->size() > 1) {
    const long messages = std::lround(double(after.exchanges - before.exchanges) / steps);
    const double per_step = (after.bytes - before.bytes) / steps;
    const std::size_t size = messages > 0 ? std::size_t(per_step / double(messages)) : 0;
    std::vector<char> out(size, 1), in(size);
    const int up = (dec->rank() + 1) % dec->size(), down = (dec->rank() + dec->size() - 1) % dec->size();
    for (int rep = 0; rep < 4; ++rep) {  // the first as warm-up
      MPI_Barrier(MPI_COMM_WORLD);
      const double w0 = MPI_Wtime();
      for (long m = 0; m < messages; ++m)
        MPI_Sendrecv(out.data(), int(size), MPI_BYTE, m % 2 ? up : down, 7, in.data(), int(size), MPI_BYTE,
                     m % 2 ? down : up, 7, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      if (rep > 0) transfer += (MPI_Wtime() - w0) / 3;
    }
  }
  // The interconnect's own figures for the cost model (docs/theory/scale-out.md): alpha, the one-way time of an 8-byte
  // message between ranks 0 and 1 (half a ping-pong round trip), beta, the one-way bandwidth of 4 MiB messages, and
  // an 8-byte all-reduce over all ranks; best of 5 rounds of 200 (alpha, all-reduce) or 10 (beta) each. With them the
  // model prices the step's exchanges, messages x alpha + bytes / beta (each way), beside the replay above.
  double alpha = 0, beta = 0, beta_exchange = 0, allreduce = 0, modelled = 0;
  if (dec->size() > 1) {
    auto pingpong = [&](std::size_t bytes, int reps) {
      std::vector<char> buf(bytes, 1);
      double best = 1e30;
      for (int round = 0; round < 5; ++round) {
        MPI_Barrier(MPI_COMM_WORLD);
        const double w0 = MPI_Wtime();
        for (int r = 0; r < reps; ++r) {
          if (dec->rank() == 0) {
            MPI_Send(buf.data(), int(bytes), MPI_BYTE, 1, 9, MPI_COMM_WORLD);
            MPI_Recv(buf.data(), int(bytes), MPI_BYTE, 1, 9, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
          } else if (dec->rank() == 1) {
            MPI_Recv(buf.data(), int(bytes), MPI_BYTE, 0, 9, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            MPI_Send(buf.data(), int(bytes), MPI_BYTE, 0, 9, MPI_COMM_WORLD);
          }
        }
        best = std::min(best, (MPI_Wtime() - w0) / (2.0 * reps));
      }
      return best;  // one way
    };
    alpha = pingpong(8, 200);
    const std::size_t big = std::size_t(4) << 20;
    beta = double(big) / (pingpong(big, 10) - alpha);
    // A halo exchange sends and receives at once: ranks 0 and 1 swap 4 MiB (MPI_Sendrecv), the bandwidth each
    // direction gets when both move (on one machine they share its memory; a full-duplex link gives each its own).
    {
      std::vector<char> out(big, 1), in(big);
      double best_x = 1e30;
      for (int round = 0; round < 5; ++round) {
        MPI_Barrier(MPI_COMM_WORLD);
        const double w0 = MPI_Wtime();
        for (int r = 0; r < 10; ++r)
          if (dec->rank() < 2)
            MPI_Sendrecv(out.data(), int(big), MPI_BYTE, 1 - dec->rank(), 11, in.data(), int(big), MPI_BYTE,
                         1 - dec->rank(), 11, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        best_x = std::min(best_x, (MPI_Wtime() - w0) / 10);
      }
      beta_exchange = double(big) / (best_x - alpha);
    }
    double best = 1e30;
    for (int round = 0; round < 5; ++round) {
      double v = 1;
      MPI_Barrier(MPI_COMM_WORLD);
      const double w0 = MPI_Wtime();
      for (int r = 0; r < 200; ++r) MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
      best = std::min(best, (MPI_Wtime() - w0) / 200);
    }
    allreduce = best;
    // rank 0's step: each exchange sends and receives one plane message per cut (one cut on an end rank)
    modelled = double(after.exchanges - before.exchanges) / steps * alpha +
               (after.bytes - before.bytes) / steps / beta_exchange;
  }
  const std::string label = moth ? "hawkmoth " + std::to_string(g.shape().nx) + "x" + std::to_string(g.shape().ny) +
                                       "x" + std::to_string(g.shape().nz)
                                 : std::to_string(n) + "^3";
  if (dec->rank() == 0)
    std::printf("ranks %d threads %d cells %s steps %d: %.1f ns per cell step (whole grid), %.2f s, %.2f pressure "
                "iterations per step, kinetic energy %.12e%s; rank 0 per step: %.1f exchanges, %.3g bytes sent, "
                "%.1f gathers, %.1f reductions; slab of %d planes; ms per step in communication, by rank: %s "
                "(of %.0f; the transfers alone %.1f); interconnect: alpha %.2f us, beta %.2f GB/s one way, "
                "%.2f GB/s each way in an exchange, all-reduce %.2f us; the step's exchanges at these figures "
                "(messages x alpha + bytes / exchange beta) %.1f ms\n",
                dec->size(), omp_get_max_threads(), label.c_str(), steps, seconds * 1e9 / (double(steps) * g.cells()),
                seconds,
                double(cycles) / steps, energy,
                moth ? (", force " + std::to_string(force.x()) + " " + std::to_string(force.y()) + " " +
                        std::to_string(force.z()) + " N").c_str()
                     : "",
                double(after.exchanges - before.exchanges) / steps,
                (after.bytes - before.bytes) / steps, double(after.gathers - before.gathers) / steps,
                double(after.reductions - before.reductions) / steps, s.slab().n, comm_text.c_str(),
                1e3 * seconds / steps, 1e3 * transfer, 1e6 * alpha, beta / 1e9, beta_exchange / 1e9,
                1e6 * allreduce, 1e3 * modelled);
  MPI_Finalize();
  return 0;
}
