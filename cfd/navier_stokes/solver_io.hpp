// Checkpoints and flow-field output of a Solver on any number of ranks (decomposition.hpp): the files are those of
// the whole grid, the same as one rank writes (flapstab cfd's checkpoint layout, docs/cfd-files.md), written by
// rank 0, so a run can be restarted on another number of ranks and ParaView opens one data set. Every rank must make
// the same calls. Checkpoints reach rank 0 one slab of one array at a time (write_state_over_ranks); whole field
// files are gathered there (Debian's serial HDF5 is the one linked: no parallel HDF5).
#pragma once
#include <map>
#include <string>
#include <vector>
#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/simulation.hpp"
#include "cfd/navier_stokes/solver.hpp"

namespace flapstab::ns {

// The solver's state on the whole grid, on rank 0 (elsewhere the fields are empty): velocity, pressure, the Poisson
// initial guesses, time, and the given step counter and last step.
SimulationState gather_state(const Solver& s, long step, double dt_last);

// transfer_state over ranks (a free flight's re-planned fine box): rank 0 holds the whole state `whole` of grid
// `from` (the other ranks its time, step and last dt, e.g. gather_state's), and each rank receives its slab of `to`'s
// grid, ghost planes included, computed on rank 0 one slab at a time: the planes of transfer_state on the whole new
// grid, and no rank holds that. On one rank, transfer_state. Collective.
SimulationState transfer_state_over_ranks(const SimulationState& whole, const Grid& from, const Solver& to);

// A checkpoint's state of the whole grid `whole` as this rank holds it: over several ranks only its slab's planes
// (ghost planes included) are read, the whole file streamed through for its checksums, so no rank holds the whole
// grid; on one rank the whole state. Simulation::restore takes either.
SimulationState read_state_over_ranks(const CheckpointReader& ck, const Grid& whole, const Decomposition& ranks);

// Rank 0's side of slabs the other ranks send it (Decomposition::send_to) in an order both sides know: a writer takes
// them one by one as it goes, and when it fails the rest are taken in and dropped (drain), so that every send
// completes and no rank is left waiting.
class RootInbox {
 public:
  explicit RootInbox(const Decomposition& D) : D_(D) {}
  void expect(int from, std::size_t count, int tag) { queue_.push_back({from, count, tag}); }
  // The next message, into `out` (resized to its count).
  void next(std::vector<double>& out);
  // Receives and drops every message not taken yet.
  void drain();

 private:
  struct Message {
    int from;
    std::size_t count;
    int tag;
  };
  const Decomposition& D_;
  std::vector<Message> queue_;
  std::size_t taken_ = 0;
};

// The planes of this rank's slab (ghost planes included) of a whole-grid state, or the state itself when its fields
// are not the whole grid's or there is one rank.
SimulationState own_planes(const SimulationState& whole, const Solver& s);
// The ranks' z slabs of the solver's grid for a log line, e.g. "6 + 6 + 6 + 6".
std::string slab_planes_text(const Solver& s);

// Cells of this rank's slab (x fastest, nx * ny * n values) gathered into the whole grid's cells on rank 0 (empty
// elsewhere). Collective.
std::vector<double> gather_cells(const Solver& s, std::vector<double> own);

// The velocity and pressure of the whole grid gathered on rank 0 (u and p are set there, left empty elsewhere).
// Collective.
void gather_flow(const Solver& s, VectorField& u, Field& p);

// The solver's state written as a checkpoint of the whole grid (write_state's file: arrays u0 u1 u2 p phi0 phi1 phi2
// bit for bit, header state_header), collectively: rank 0 writes, receiving each other rank's planes of one array at
// a time, so no rank holds the whole grid; an error there (a directory that cannot be written) is thrown on every
// rank, after rank 0 has taken in every message still on its way.
void write_state_over_ranks(const std::string& path, const Solver& s, long step, double dt_last,
                            std::map<std::string, double> values, std::map<std::string, std::string> text);

// The same with the number of ranks that wrote it in the header (value "ranks").
void write_solver_checkpoint(const std::string& path, const Solver& s, long step, double dt_last,
                             std::map<std::string, double> values = {}, std::map<std::string, std::string> text = {});

// Restores s from a checkpoint of its whole grid, whichever number of ranks (or flapstab cfd run without bodies)
// wrote it: every rank reads the file and keeps its planes. Returns the state's time, step and last dt (the fields
// of the returned state are empty). InputError naming the file for a missing one or another grid's.
SimulationState read_solver_checkpoint(const std::string& path, Solver& s);

// Cell-centred velocity (m/s), pressure (Pa: density times the solver's kinematic pressure), vorticity and Q of the
// whole grid through `writer` (one HDF5 + XDMF file per output and the series; the writer exists on rank 0 only,
// null elsewhere). Returns the .h5 path on rank 0, "" elsewhere.
std::string write_solver_fields(FieldWriter* writer, const Solver& s, double density, long step);

}  // namespace flapstab::ns
