// The AeroModel over the CFD solver (trim, derivatives and analyze with [aero] model = "cfd"): periodic loads of
// the hover and of its perturbations, each run from one kept periodic hover state.
//
// 1. Base hover, computed once: the first kinematics asked for are run from rest in quiescent air for at least
//    [aero.cfd] cycles wingbeats and until the cycle-to-cycle change of the mean loads is below hover_tolerance
//    (max_cycles at most); that state is kept. Its last wingbeat is the hover's answer.
// 2. Reference: the hover continued from the kept state, wingbeat by wingbeat, as far as any perturbed run goes.
// 3. Every other request (a steady body motion, other kinematics, or both) starts from the kept hover state on
//    the same grid (it is fixed to the body, cfd/navier_stokes/insect_motion.hpp). After wingbeat k its
//    difference from the reference at the same wingbeat, d_k = W_k - W_ref,k, is averaged over the second half of
//    its wingbeats (k/2 + 1 .. k: the perturbation's start-up left out); the run stops when the standard error of
//    that mean is below perturbation_tolerance (at least 3 wingbeats, so 2 in the window). Its answer is the base
//    hover's last wingbeat plus the window's mean d at every phase. The hover's own drift is common to both and
//    cancels in d; the wingbeat-to-wingbeat scatter that does not (coarse grids at Re ~ 1000 are close to
//    chaotic) is averaged down and reported as the standard error.
// With [aero.cfd.fpm] the continued hover and every run of the base hover's kinematics without body rates are
// force-partitioned as well, and each keeps the window mean of its partition's difference from the continued hover
// (CfdRunRecord::partition): the split of the velocity derivatives by mechanism. Runs with rates turn the grid, where
// the partition does not hold; runs of other kinematics (a CFD trim's iterates) are not split.
// Tolerances: fractions of the weight (forces) and of weight x mean chord (moments). Each run reports its cycles,
// final change and wall time (records()); with a cache directory every finished run and the kept states are saved
// there and reused when the same case is run again (a killed analysis resumes without recomputing).
#pragma once
#include <array>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include "cfd/navier_stokes/oscillation.hpp"
#include "cfd/navier_stokes/periodic.hpp"
#include "cfd/navier_stokes/simulation.hpp"
#include "core/aero_model.hpp"
#include "core/case_file.hpp"

namespace flapstab::ns {

// Means of the force partition ([aero.cfd.fpm], docs/theory/force-partitioning.md) of a run, summed over the
// partitioned parts: per partitioned load component (0 .. 5: Fx Fy Fz Mx My Mz in stability axes, moments about O;
// N, N m), the cut-cell pressure load the parts should sum to, the parts, and at the same samples the run's own
// pressure and skin-friction loads (its forces.csv).
struct PartitionMeans {
  // centripetal: the CAR, part of kinematic; pressure_forced: the share of pressure on the faces the immersed
  // boundary forces (fpm::PartPartition)
  enum Term {
    pressure, kinematic, centripetal, vortex, viscous, outer, run_pressure, run_friction, pressure_forced, terms
  };
  // The partition's definition, kept with a cached partition: one cached under another (an earlier flapstab's: 1,
  // whose viscous part summed the forced faces too; 2, before [aero.cfd.fpm] body) or with another body is not
  // reused.
  static constexpr int definition = 3;
  static const char* term_name(int t);
  std::string body = "surface";  // [aero.cfd.fpm] body
  std::vector<int> components;
  std::vector<std::array<double, terms>> values;  // one row per component
};

struct CfdRunRecord {
  std::string label;              // "hover", or the motion / kinematics change
  BodyMotion motion;
  bool other_kinematics = false;  // kinematics differ from the base hover's
  // Cycle means of the run; change: cycle-to-cycle change (hover), or the standard error of the window's mean d
  // (perturbed runs), fractions of the weight (moments of weight x mean chord).
  std::vector<CycleRecord> cycles;
  bool converged = false;
  double wall_seconds = 0;
  bool reused = false;            // read from the cache directory
  // With [aero.cfd.fpm], for a run without body rates (the partition needs an inertial grid frame): the window mean
  // of the partition's difference from the continued hover, like the loads' (the derivatives' split by mechanism).
  std::optional<PartitionMeans> partition;
  double final_change() const { return cycles.empty() ? -1 : cycles.back().change; }
  double final_drift() const { return cycles.empty() ? -1 : cycles.back().drift; }
};

class CfdModel final : public AeroModel {
 public:
  explicit CfdModel(Case c, std::ostream* log = &std::cerr, std::string cache_directory = {});
  ~CfdModel() override;
  std::string name() const override { return "navier-stokes-ib"; }
  // options.cycles > [aero.cfd] cycles raises the hover's minimum; samples_per_cycle resamples (0: one sample per
  // time step).
  WrenchHistory run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                    const AeroRunOptions& options) const override;

  // Runs every flow over these ranks (a group of an MPI job, Decomposition::split): each rank holds its slab of the
  // grid, and every rank of the group must call the same methods in the same order with the same arguments; rank 0
  // reads and writes the cache and takes its locks for the group (another group, or another process, sharing the
  // cache directory is a campaign member like any). Only rank 0 writes to the log. Force partitioning
  // ([aero.cfd.fpm]) over several ranks is bad input (InputError). Call before the first run.
  void run_over(std::shared_ptr<const Decomposition> ranks);

  // Further kinematics the shared grid must hold (e.g. a trim's parameter bounds); call before the first run.
  void plan_for(std::vector<Kinematics> kinematics) { plan_for_ = std::move(kinematics); }

  // Every run so far, the base hover first.
  const std::vector<CfdRunRecord>& records() const;
  // The grid every run shares (after the first run), and the reference continuation's cycle means.
  const CfdPlan* plan() const;
  // The kept periodic hover state (the base hover's last wingbeat ends in it; after the first run), else nullptr:
  // free flight coupled to the solver starts from it.
  // Over several ranks (run_over) this rank's slab (read from the cache plane by plane).
  const SimulationState* hover_state() const;
  // The base hover's run record (after the first run), else nullptr.
  const CfdRunRecord* hover_record() const { return records().empty() ? nullptr : &records().front(); }
  const std::vector<CycleRecord>& reference_cycles() const;

  // A forced pitch oscillation about the kept hover state (oscillation.hpp; the hover's kinematics only, made first
  // if need be): the body turned about O in the hover's grid, its loads in body axes against the continued hover,
  // per wingbeat, and their fits. With a cache directory the run keeps its state and wingbeats after every wingbeat
  // (pitch_<key>.h5 / .json): a killed run resumes, and a later call asking for more periods continues it.
  PitchOscillationResult pitch_oscillation(const Insect& insect, const Kinematics& kin,
                                           const PitchOscillationSpec& spec) const;

 private:
  // Extends the continued hover to k wingbeats (shared with other processes through the cache).
  void continue_reference(int k) const;
  struct State;
  Case case_;
  std::ostream* log_;
  std::string cache_;
  std::vector<Kinematics> plan_for_;
  std::shared_ptr<const Decomposition> ranks_;  // one rank without MPI unless run_over
  std::unique_ptr<State> st_;
};

}  // namespace flapstab::ns
