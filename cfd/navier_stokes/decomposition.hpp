// Domain decomposition of the Navier-Stokes grid over MPI ranks: slabs along z, one per rank, with one layer of
// ghost planes exchanged between neighbours, and the global reductions the solver needs.
#pragma once
#include <memory>
#include <vector>
#include "cfd/navier_stokes/field.hpp"

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

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool distributed() const { return size_ > 1; }

  // The slabs of a z axis of `cells` cells split into whole `unit`s of planes, as evenly as possible (lower ranks
  // take the extra units); throws std::invalid_argument when there are fewer units than ranks.
  std::vector<Slab> slabs(int cells, int unit, bool periodic) const;
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

  double sum(double v) const;
  void sum(double* v, int n) const;  // element-wise, in place
  double max(double v) const;

  // What this rank has communicated since construction (for the cost model in docs/theory/scale-out.md): ghost
  // exchanges (each one or two plane messages), the bytes it sent in them and in gathers, and all-reductions.
  struct Traffic {
    long exchanges = 0, gathers = 0, reductions = 0;
    double bytes = 0;
  };
  const Traffic& traffic() const { return traffic_; }

 private:
  mutable Traffic traffic_;
  struct Comm;
  std::unique_ptr<Comm> comm_;
  int rank_ = 0, size_ = 1;
};

}  // namespace flapstab::ns
