// The CFD run as a stepping simulation: planned, restored from a state, advanced one step at a time, observed.
//
//   Simulation sim(case, kin, motion, plan);      // grid, boundaries, solver, the insect's immersed parts (3 or 5)
//   sim.restore(state);                           // optional: an exact continuation (checkpoint, kept hover state)
//   while (...) { StepReport r = sim.advance(); } // one RK3 step, the loads of every part, finiteness/CFL checks
//
// The grid is fixed to the body (InsectMotion): its axes are the body's stability axes, origin O. Far field: the
// still air seen from the body, -V - Omega x r, prescribed on five faces (zero in hover: quiescent air at rest);
// the face below the insect (+z) is a zero-gradient outflow with p = 0, where the downwash leaves. With rates
// Omega the frame turns: Coriolis acceleration in the momentum equation, reduced pressure (SolverOptions), and
// the centrifugal pressure's load on closed parts added back; a rate that changes in time (a forced oscillation)
// adds the Euler acceleration (SimulationOptions::frame_rotation). Loads in the body's stability axes, moments
// about O.
//
// The parts' kinematics (pose, velocity, acceleration) are handed to the immersed boundary as values at every
// Runge-Kutta stage time (ImmersedBoundary::set_parts): InsectMotion computes them here; a free-flight driver
// can replace it (set_motion).
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include "cfd/navier_stokes/forces_csv.hpp"
#include "cfd/navier_stokes/immersed.hpp"
#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "cfd/navier_stokes/solver.hpp"
#include "core/errors.hpp"

namespace flapstab::ns {

struct SimulationOptions {
  bool bodies = true;  // false: a body-free flow in the same box (solver checks, tests)
  std::function<Vec3(double x, double y, double z)> initial_velocity;  // default: the uniform stream -V
  ImmersedOptions::Contact contact = ImmersedOptions::Contact::gap;  // where two parts meet (ImmersedOptions::contact)
  // A frame whose rate changes in time: the body, and the grid fixed to it, turns about O at rate(t) (rad/s, grid
  // axes), with rate_rate(t) = d rate / dt (rad/s^2); e.g. a forced pitch oscillation, in which the body keeps its
  // cells. The solver carries the Coriolis and Euler accelerations (SolverOptions::frame_rate_at), the far field
  // is -V - rate(t) x r, the parts' apparent accelerations and the centrifugal pressure's load follow rate(t). The
  // simulation must be planned with no steady rate (BodyMotion::rate = 0).
  struct FrameRotation {
    std::function<Vec3(double t)> rate{}, rate_rate{};
  } frame_rotation{};
  // The grid split over MPI ranks (decomposition.hpp): the solver and the immersed boundary run on this rank's
  // slab, the loads are the whole insect's on every rank. state() is the slab's, whole_state() the whole grid's on
  // rank 0; restore() takes either; run_cfd (CfdRunOptions::decomposition) writes a run directory from the ranks.
  std::shared_ptr<const Decomposition> decomposition{};
  // > 0: the pressure solves' relative tolerance instead of the solver's (1e-3). Two runs that must agree to
  // round-off (over ranks and on one) need a tight one: at 1e-3 a residual within round-off of its target can take
  // one more iteration on one side, and the runs then differ by far less than the tolerance but more than round-off.
  double pressure_rtol = 0;
};

// Everything a step depends on (one checkpoint schema): restoring it continues the run bit for bit.
struct SimulationState {
  double time = 0;   // s
  long step = 0;
  double dt_last = 0;  // s
  VectorField u, phi;  // face velocity (m/s), the last step's pressure increments (the Poisson initial guesses)
  Field p;             // kinematic pressure (m^2/s^2)
  bool guess = false;
};

// What one step did.
struct StepReport {
  long step = 0;              // the step counter after the step
  double t_before = 0, time = 0, dt = 0;
  double cfl = 0;
  CfdLoadRow row;             // loads at `time`
};

// A step that failed: the solver threw, the loads or the solution are not finite, or the CFL number passed the
// RK3 limit.
class StepFailure : public SolveError {
 public:
  StepFailure(long step, double time, std::string why)
      : SolveError(why), step_(step), time_(time), why_(std::move(why)) {}
  long step() const { return step_; }
  double time() const { return time_; }
  const std::string& why() const { return why_; }

 private:
  long step_;
  double time_;
  std::string why_;
};

class Simulation {
 public:
  Simulation(const Case& c, const Kinematics& kin, const BodyMotion& motion, const CfdPlan& plan,
             SimulationOptions options = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Restores a state of this simulation (an exact continuation). A state of another body motion `state_motion`
  // (e.g. the kept hover state for a perturbed run) gets this run's far field at the state's time: the difference
  // of the two far fields, -dV - dOmega x r, is added to the velocity everywhere (the body's motion starts
  // impulsively; the pressure is left as it was, and the first projection makes it the new flow's).
  // Over ranks the state may be the whole grid's (a checkpoint, whole_state()) on every rank, which keeps its
  // planes, or this rank's slab's (state()).
  void restore(const SimulationState& state, const BodyMotion& state_motion);
  void restore(const SimulationState& state);
  SimulationState state() const;  // this rank's slab (the whole grid on one rank)
  // The whole grid's state on rank 0, gathered from the ranks (empty fields elsewhere); state() on one rank.
  // Collective: every rank calls it.
  SimulationState whole_state() const;
  // One time step; throws StepFailure.
  StepReport advance();

  const Case& case_file() const { return case_; }
  const Kinematics& kinematics() const { return kin_; }
  const BodyMotion& motion() const { return motion_; }
  const CfdPlan& plan() const { return plan_; }
  const Grid& grid() const;        // this rank's slab (the whole grid on one rank)
  const Grid& whole_grid() const;  // the whole grid, whichever the ranks
  const Solver& solver() const;
  long step() const { return step_; }
  double time() const;
  double last_dt() const { return dt_last_; }
  std::size_t cells() const;  // of the whole grid
  std::size_t bytes() const;  // solver + immersed boundary (this rank's)
  bool has_bodies() const;
  // The loads at the current time (the last step's row; before any step, computed).
  CfdLoadRow loads() const;
  // Parts of the insect's geometry: 3 (body, right, left), or 5 with a hind pair (hind_right, hind_left; part_names).
  // The loads' rows carry as many, zero without bodies.
  int part_count() const;
  // Surface of a part (0 body, 1 right, 2 left, 3 hind_right, 4 hind_left) at the current time, grid axes, and its
  // pressure (Pa).
  TriangleMesh surface(int part) const;
  SurfacePressure surface_pressure(int part) const;
  // The parts' kinematics at the current time (the order of part_names; grid axes); empty without bodies.
  std::vector<PartState> part_states() const;
  // The parts' kinematics relative to the body (body axes, origin O) at time t as the prescribed wing motion gives
  // them, whatever moves the body: with a steady body motion the grid is the body's frame and these are what the
  // immersed boundary takes; empty without bodies.
  std::vector<PartState> prescribed_parts(double t) const;
  // Replaces the prescribed kinematics the immersed boundary takes at every stage time (and at restore) by a
  // driver's: a free-flight coupling moves the parts with the body through a grid fixed in space (the simulation
  // must then be planned with no body motion: still air, no turning frame). An empty function restores the
  // prescribed motion. The loads' wing power then uses the driver's velocities. Call before advance().
  using PartSource = std::function<std::vector<PartState>(double t)>;
  void set_part_source(PartSource source);
  // Volume (m^3) of a closed part (0 for a membrane) and its centroid in body axes at t = 0 (the body is fixed in
  // its own frame): the buoyancy of a body in a grid fixed in space, whose pressure carries no hydrostatics.
  double part_volume(int part, Vec3* centroid = nullptr) const;
  // The immersed boundary holding the parts (nullptr for a body-free simulation).
  const ImmersedBoundary* immersed() const;
  // 1 in cells inside a part at the current time, else 0 (ImmersedBoundary::solid_mask; all 0 without bodies): the
  // cells of grid(), x fastest.
  std::vector<double> solid_mask() const;

 private:
  struct Impl;
  Case case_;
  Kinematics kin_;
  BodyMotion motion_;
  CfdPlan plan_;
  std::unique_ptr<Impl> impl_;
  long step_ = 0;
  double dt_last_ = 0;
};

// The state carried over to another grid of the same still air (a free flight's re-planned fine box): each
// staggered velocity component and the pressure interpolated (trilinearly, on their own lattices: faces along the
// component, cell centres across) at the new grid's points, still air (zero velocity and pressure) where the new
// grid reaches beyond the old domain, nearest values between a domain face and its first cell centre. Time, step and
// the last dt are kept; the Poisson initial guesses are dropped (guess = false). Where the fine cells of the two
// grids coincide (shifted_plan) the values are copied to rounding; elsewhere the interpolated velocity is not
// discretely divergence-free, and the next step's projection makes it so.
SimulationState transfer_state(const SimulationState& s, const Grid& from, const Grid& to);

// Checkpoint files of a simulation state (HDF5, docs/cfd-files.md): arrays u0 u1 u2 p phi0 phi1 phi2 bit for bit,
// header time, step, dt, guess plus the given values and texts.
void write_state(const std::string& path, const SimulationState& s, std::map<std::string, double> values,
                 std::map<std::string, std::string> text);
// The same file written from a simulation over any number of ranks, collectively: rank 0 writes it, receiving the
// other ranks' planes one slab of one array at a time (no rank holds the whole grid), and an error there (a directory
// that cannot be written) is thrown on every rank.
void write_state(const std::string& path, const Simulation& sim, std::map<std::string, double> values,
                 std::map<std::string, std::string> text);
// The header write_state gives a state: its time and step, and the values dt and guess beside the given ones.
CheckpointHeader state_header(double time, long step, double dt_last, bool guess, std::map<std::string, double> values,
                              std::map<std::string, std::string> text);
// InputError naming the file and array for a checkpoint without the state or of another grid shape.
SimulationState read_state(const CheckpointReader& ck, const Shape& shape);
// The planes of a slab of the whole grid `whole` (its own planes and ghost planes, as Simulation::state() over ranks
// holds them), read without the whole state in memory (CheckpointReader::read_rows; every array's checksum checked).
SimulationState read_state(const CheckpointReader& ck, const Shape& whole, const Slab& slab);

}  // namespace flapstab::ns
