// Observers of a Simulation: what a run writes and prints, each a small object called after every step
// (forces.csv, flow fields, surfaces, checkpoints, progress, run.json; docs/cfd-files.md).
#pragma once
#include <chrono>
#include <functional>
#include <iosfwd>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include "cfd/navier_stokes/diagnostics.hpp"
#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/io_vtk.hpp"
#include "cfd/navier_stokes/simulation.hpp"

namespace flapstab::ns {

class StepObserver {
 public:
  virtual ~StepObserver() = default;
  virtual void on_start(const Simulation&) {}
  virtual void on_step(const Simulation& sim, const StepReport& report) = 0;
  virtual void on_end(const Simulation&) {}
};

// True when [ta, tb] crosses one of `per_cycle` equally spaced instants per period (none for per_cycle <= 0).
bool crossed(int per_cycle, double period, double ta, double tb);

// Every row of the run; forces.csv written atomically by flush() and at the end ("" path: in memory only). On a
// restart the rows of the interrupted run up to the checkpoint come first.
class ForcesCsv final : public StepObserver {
 public:
  // `parts`: the geometry's part count (Simulation::part_count), for the header.
  explicit ForcesCsv(std::string path, int parts = 3) : path_(std::move(path)), parts_(parts) {}
  // Reads the rows of an earlier forces.csv up to and including `step` (a restart from that step). They must be
  // there, steps first_step ... step in order: otherwise InputError naming the file and the line.
  void keep_earlier(const std::string& file, long step, long first_step = 1);
  void on_step(const Simulation&, const StepReport& r) override;
  void on_end(const Simulation&) override { flush(); }
  // Writes the file (rank 0 of a decomposed run: flush is then collective, and its failure every rank's).
  void flush() const;
  // The ranks of a decomposed run (run_cfd): only rank 0 writes; null (the default) for one process.
  void set_decomposition(std::shared_ptr<const Decomposition> d) { dec_ = std::move(d); }
  const std::vector<CfdLoadRow>& rows() const { return rows_; }        // this run's
  const std::vector<CfdLoadRow>& earlier() const { return earlier_; }  // the interrupted run's
  // Rows (earlier and this run's) with time > t - 1e-9 period.
  std::vector<CfdLoadRow> since(double t, double period) const;

 private:
  std::string path_;
  int parts_ = 3;
  std::shared_ptr<const Decomposition> dec_;
  std::vector<CfdLoadRow> rows_, earlier_;
  std::vector<std::string> lines_;
};

// Checkpoints per wingbeat (and at the end), keeping the newest `keep`; each flushes forces.csv first, so the rows
// always reach the newest checkpoint's step. A decomposed run's checkpoint is the whole grid's, written by rank 0.
class Checkpointer final : public StepObserver {
 public:
  Checkpointer(std::string directory, int per_cycle, std::map<std::string, double> values,
               std::map<std::string, std::string> text, const ForcesCsv* csv, int keep = 2)
      : dir_(std::move(directory)), per_cycle_(per_cycle), values_(std::move(values)), text_(std::move(text)),
        csv_(csv), keep_(keep) {}
  void write(const Simulation& sim);
  void on_step(const Simulation& sim, const StepReport& r) override;
  void on_end(const Simulation& sim) override {
    if (last_step_ != sim.step()) write(sim);
  }
  void set_last(std::string path, long step) { last_ = std::move(path), last_step_ = step; }
  // Another file to flush before each checkpoint (as forces.csv: its rows always reach the newest checkpoint).
  void also_flush(std::function<void()> f) { flush_.push_back(std::move(f)); }
  const std::string& last() const { return last_; }
  long last_step() const { return last_step_; }

 private:
  std::string dir_;
  int per_cycle_;
  std::map<std::string, double> values_;
  std::map<std::string, std::string> text_;
  const ForcesCsv* csv_;
  std::vector<std::function<void()>> flush_;
  int keep_;
  std::string last_;
  long last_step_ = -1;
};

// An output written per_cycle times per wingbeat (and whenever write() is called).
class PerCycleOutput : public StepObserver {
 public:
  PerCycleOutput(std::string directory, int per_cycle) : dir_(std::move(directory)), per_cycle_(per_cycle) {}
  virtual void write(const Simulation& sim) = 0;
  void on_step(const Simulation& sim, const StepReport& r) override {
    if (crossed(per_cycle_, sim.plan().period, r.t_before, r.time)) write(sim);
  }

 protected:
  std::string dir_;
  int per_cycle_;
};

// Cell-centred velocity, pressure (Pa), vorticity and Q criterion (HDF5 + XDMF) of the whole grid. Over MPI ranks
// each rank computes its own planes' fields, and rank 0 writes the one file, taking each field's planes from the
// ranks one slab at a time (no rank holds a whole field; a periodic z axis is gathered on rank 0 instead).
class FieldOutput final : public PerCycleOutput {
 public:
  // per_rank: over MPI ranks each rank writes its own planes (a piece file, fields_STEP.pRANK.h5) and rank 0 the XDMF
  // over the pieces, instead of one file (a z axis that is not periodic; a periodic one is gathered).
  FieldOutput(std::string directory, int per_cycle, FieldPrecision precision, bool per_rank = false)
      : PerCycleOutput(std::move(directory), per_cycle), precision_(precision), per_rank_(per_rank) {}
  void write(const Simulation& sim) override;

 private:
  void write_pieces(const Simulation& sim);
  void write_streamed(const Simulation& sim);
  FieldPrecision precision_;
  bool per_rank_ = false;
  RectilinearAxes axes_;  // the writer's grid
  std::optional<FieldWriter> writer_;
};

// The parts' surfaces with their pressure (VTK PolyData series; rank 0 writes a decomposed run's).
class SurfaceOutput final : public PerCycleOutput {
 public:
  using PerCycleOutput::PerCycleOutput;
  void write(const Simulation& sim) override;

 private:
  std::optional<SurfaceWriter> writer_;
};

// Timings (the estimate after two steps, the measured cost per step) and progress lines with the ETA.
class ProgressLog final : public StepObserver {
 public:
  using clock = std::chrono::steady_clock;
  // end_step > 0: the run ends at that step (fixed dt); else at end_time.
  ProgressLog(std::ostream* log, double seconds, long end_step, double end_time)
      : log_(log), seconds_(seconds), end_step_(end_step), end_time_(end_time) {}
  void on_start(const Simulation&) override;
  void on_step(const Simulation& sim, const StepReport& r) override;
  bool estimated() const { return warm_steps_ >= 2; }
  double seconds_per_step_estimate() const { return estimate_; }
  // Measured over the steps after the first two (the estimate if there were no more).
  double seconds_per_step() const;
  double steps_left(const Simulation& sim, double dt) const;

 private:
  std::ostream* log_;
  double seconds_;
  long end_step_;
  double end_time_;
  clock::time_point start_, last_log_, after_warmup_;
  long warm_steps_ = 0;
  double estimate_ = 0;
};

std::string fmt_seconds(double s);
// The cell-face coordinates of a grid's interior cells (the field files' axes).
RectilinearAxes rectilinear(const Grid& g);

// The cell-centred fields of a field file: velocity (m/s), pressure (Pa: density times the kinematic pressure),
// vorticity (1/s) and the Q criterion (1/s^2), in that order; fields() points into the arrays held here.
struct FlowFields {
  CentreFields centre;
  std::vector<double> pressure;
  std::vector<CellField> fields() const;
};
FlowFields flow_fields(const Grid& g, const VectorField& u, const Field& p, double density);
// The checkpoint files checkpoint_STEP.h5 in a directory, by step.
std::vector<std::pair<long, std::string>> checkpoints_in(const std::string& dir);

}  // namespace flapstab::ns
