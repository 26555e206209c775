// Domain decomposition of the Navier-Stokes grid over MPI ranks: slabs along z, one per rank, with one layer of
// ghost planes exchanged between neighbours, and the global reductions the solver needs.
#pragma once
#include <exception>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>
#include "cfd/navier_stokes/field.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

// The planes a rank owns along the decomposed axis (z): global cells offset + 1 .. offset + n (1-based, as in the
// padded index space), and whether its lower and upper faces are cuts (their ghost planes come from a neighbour).
struct Slab {
  int offset = 0, n = 0;
  bool cut_lo = false, cut_hi = false;
};

// A communicator and the z slabs over it. The default is one rank without MPI: every operation is the identity
// (reductions return their argument, exchanges do nothing), so the solver's single-process path is unchanged.
// With MPI (built when CMake finds it; `world()` after MPI_Init), rank r owns the r-th slab; neighbours are
// r - 1 and r + 1, wrapped when the global z axis is periodic. Collective operations must be called by every
// rank in the same order.
class Decomposition {
 public:
  Decomposition();  // one rank
  ~Decomposition();
  // All ranks of MPI_COMM_WORLD (MPI must be initialised); throws when flapstab was built without MPI.
  static std::shared_ptr<const Decomposition> world();
  static bool mpi_available();  // built with MPI
  // How many processes an MPI launcher started together with this one (Open MPI's OMPI_COMM_WORLD_SIZE, or PMI_SIZE
  // of MPICH and other PMI launchers): 1 when none did.
  static int launched_processes();
  // The ranks of a run started by mpiexec: when the launcher started more than one process, MPI is initialised
  // (once; finalised at exit) and all of MPI_COMM_WORLD is returned; otherwise one rank without MPI. Throws
  // std::runtime_error for several processes when flapstab was built without MPI.
  static std::shared_ptr<const Decomposition> launched();
  // Ends every process of the job at once with this exit status (MPI_Abort on MPI_COMM_WORLD): for an error only
  // some ranks met, while the others may wait in a collective operation. Without MPI: std::exit.
  [[noreturn]] void abort(int status) const;

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool distributed() const { return size_ > 1; }

  // This communicator's ranks in groups of `per_group` consecutive ranks, each group a decomposition of its own (its
  // own ranks 0 .. per_group - 1, its own collective operations): for several flows at once in one job, a flow per
  // group (a campaign's runs). The size must be a multiple of per_group (std::invalid_argument otherwise).
  // Collective over this communicator.
  std::shared_ptr<const Decomposition> split(int per_group) const;
  int group() const { return group_; }    // which group of the communicator split() was called on (0 otherwise)
  int groups() const { return groups_; }  // how many groups it made (1 otherwise)
  // The MPI communicator (a pointer to an MPI_Comm; null for one rank without MPI), for libraries that take one
  // (hypre).
  const void* communicator() const;

  // The slabs of a z axis of `cells` cells split into whole `unit`s of planes over `ranks` ranks, as evenly as
  // possible (lower ranks take the extra units); throws std::invalid_argument when there are fewer units than ranks.
  static std::vector<Slab> slabs_of(int cells, int unit, int ranks, bool periodic);
  std::vector<Slab> slabs(int cells, int unit, bool periodic) const { return slabs_of(cells, unit, size_, periodic); }
  Slab slab(int cells, int unit, bool periodic) const { return slabs(cells, unit, periodic)[std::size_t(rank_)]; }

  // Ghost planes 0 and s.nz + 1 of a padded array on slab `sl`: plane 0 <- the lower neighbour's plane nz, plane
  // nz + 1 <- the upper neighbour's plane 1, at the slab's cuts only (a face that is not a cut keeps its ghosts).
  void exchange(double* x, const Shape& s, const Slab& sl) const;
  void exchange(float* x, const Shape& s, const Slab& sl) const;
  void exchange(Field& f, const Slab& sl) const { exchange(f.data(), f.shape(), sl); }

  // A slab widened by `depth` planes on each side that is a cut (a window): `window` (nz = n + depth per cut) takes
  // the local planes 0 .. n + 1 at its planes lo .. lo + n + 1 (lo = depth at a lower cut, else 0) and, at a cut, the
  // neighbour's depth + 1 planes beyond (its ghost plane included). Every neighbour must hold at least depth + 1
  // planes.
  void widen(const Field& local, const Slab& sl, int depth, Field& window) const;

  // Every rank's planes of a padded array of the whole axis (global z indices; each rank has filled its slab's
  // planes offset + 1 .. offset + n of `x`, which holds all nz planes): afterwards every rank holds all of them.
  void gather_planes(float* x, const Shape& whole, const std::vector<Slab>& slabs) const;

  // The slabs of a padded field gathered into the whole field on rank 0 (`whole`, the whole grid's shape, is
  // untouched elsewhere): each rank's planes 1 .. n, and the end ranks' outer ghost planes.
  void gather_field(const Field& local, const std::vector<Slab>& slabs, Field& whole) const;

  // Point to point (a checkpoint streamed to rank 0 one slab at a time, a re-planned grid's slabs sent from it):
  // `count` values sent to rank `to`, received from rank `from`; messages of one tag between two ranks arrive in the
  // order sent.
  void send_to(int to, const double* v, std::size_t count, int tag) const;
  void receive_from(int from, double* v, std::size_t count, int tag) const;

  double sum(double v) const;
  void sum(double* v, int n) const;  // element-wise, in place
  double max(double v) const;
  // Rank 0's text on every rank. The others wait without spinning on their cores (after a short while they poll every
  // 2 ms): rank 0 may be waiting for a file lock meanwhile.
  void broadcast(std::string& text) const;
  // Rank 0's n values on every rank (a blocking broadcast).
  void broadcast(double* v, int n) const;

  // What this rank has communicated since construction (for the cost model in docs/theory/scale-out.md): ghost
  // exchanges (each one or two plane messages), the bytes it sent in them and in gathers, all-reductions, and the
  // wall time spent in them (the transfers, and waiting for a neighbour still computing: the load imbalance).
  struct Traffic {
    long exchanges = 0, gathers = 0, reductions = 0;
    double bytes = 0;
    double seconds = 0;
  };
  const Traffic& traffic() const { return traffic_; }

 private:
  mutable Traffic traffic_;
  struct Comm;
  std::unique_ptr<Comm> comm_;
  int rank_ = 0, size_ = 1, group_ = 0, groups_ = 1;
};

// A failure every rank of a decomposed run met together (on_root), of no more particular kind.
class RanksFailed : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Runs fn on rank 0 only (a file that rank 0 reads or writes for all, a file lock it takes) and gives every rank its
// result, the text fn returns; rank 0's failure becomes every rank's, so that no rank goes on into a collective
// operation that rank 0 has left: rank 0 rethrows its InputError, OutputError or SolveError, the others throw one of
// the same kind saying that rank 0 failed; any other exception becomes RanksFailed on every rank (rank 0's with its
// message). The other ranks wait without spinning (broadcast). Every rank must call it; on one rank it is fn().
template <class Fn>
std::string from_root(const Decomposition& D, Fn&& fn) {
  if (!D.distributed()) return fn();
  std::exception_ptr error;
  std::string text;  // rank 0: a digit (the failure's kind, 0 for none), then fn's result
  if (D.rank() == 0) {
    char kind = '0';
    try {
      text = fn();
    } catch (const InputError&) {
      error = std::current_exception(), kind = '1';
    } catch (const OutputError&) {
      error = std::current_exception(), kind = '2';
    } catch (const SolveError&) {
      error = std::current_exception(), kind = '3';
    } catch (const std::exception& e) {
      error = std::make_exception_ptr(RanksFailed(e.what())), kind = '4';
    } catch (...) {
      error = std::make_exception_ptr(RanksFailed("unknown exception")), kind = '4';
    }
    text.insert(text.begin(), kind);
  }
  D.broadcast(text);
  const char kind = text.empty() ? '4' : text[0];
  if (kind == '0') return text.substr(1);
  if (D.rank() == 0) std::rethrow_exception(error);
  const std::string why = "rank 0 failed (its message says why)";
  if (kind == '1') throw InputError("", "", why);
  if (kind == '2') throw OutputError(why);
  if (kind == '3') throw SolveError(why);
  throw RanksFailed(why);
}

// Runs fn on rank 0 only (a file that rank 0 writes for all) and makes its failure every rank's (from_root).
template <class Fn>
void on_root(const Decomposition& D, Fn&& fn) {
  from_root(D, [&] {
    fn();
    return std::string();
  });
}

}  // namespace flapstab::ns
