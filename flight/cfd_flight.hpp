// Free flight coupled to the Navier-Stokes solver: the body's equations (flight/dynamics.hpp) advanced with the
// loads of the immersed-boundary CFD, the body's parts moved through the grid by the body state and the wing
// kinematics.
//
// Coupling (docs/theory/fluid-body-coupling.md):
//  - The grid is fixed in space (the inertial axes of the body state, z down; at the zero state the body's
//    stability axes and O coincide with the grid's): the far field is still air, the momentum equation has no frame
//    terms, and the body moves through the uniform fine box. [aero.cfd] fine_margin_R sets the room m around the
//    swept volume. With re-planning (set_replanning), when a part comes within m / 2 of a face of the fine box the
//    box is re-planned on the same lattice (ns::shifted_plan) around the planned swept volume carried to the body's
//    current position and attitude, plus m, and the flow is carried over to the new grid (ns::transfer_state);
//    without it, or when the new box cannot hold the parts, a part that leaves the fine box stops the run
//    (BodyLeftGrid) so that the driver can write a checkpoint.
//  - Explicit, loosely coupled: over the step t_n -> t_n+1 the body's equations are integrated with the fluid's
//    wrench at t_n held (classical Runge-Kutta, two sub-steps from t_n to each Runge-Kutta stage time of the fluid,
//    so each stage sees the body where the held loads put it, with its analytic velocity and acceleration). The
//    lag acts on the body's own acceleration reaction: a lagged added mass m_a makes the step map of the body's
//    acceleration a_n+1 = -(m_a / m) a_n + ..., stable for m_a < m. For a hawkmoth in air m_a / m is
//    estimated at 0.005-0.02 (the fluid its forcing holds solid on 8 cells per chord: 0.0056 of its mass,
//    forced_fluid_mass()); a sphere has m_a / m = rho_f / (2 rho_s) in potential flow.
//  - Gravity acts on the insect's mass (its equations), buoyancy rho_f V g on its closed parts (the solver's
//    pressure carries no hydrostatics), at their centroids.
//  - Closed loop (set_controller): the controller's terms (flight/controller.hpp) sense the deviation of the body
//    state from a reference trajectory (the unperturbed coupled flight, or the tethered hover) after their latency;
//    the deviation's history is kept at the fluid steps and interpolated linearly between them (a latency shorter
//    than a step interpolates between the last step and the current state), a sensor filter advances exactly for
//    an input linear over the step. The command moves the wings: the parts relative to the body are those of the
//    commanded kinematics with O held where the trimmed kinematics put it (as in flight/dynamics.hpp), at every
//    Runge-Kutta stage, and the body's equations carry the moved wing mass. As in the quasi-steady free flight the
//    command's own rate of change is not added to the wings' velocities; a command sampled once per wingbeat
//    (update = "wingbeat") jumps at the wingbeat's start and the wings jump with it. With the wingbeat frequency as
//    an actuator the wings' phase psi (cycles) is a state integrated with the body, dpsi/dt = f_trim + command_f,
//    and the parts are those of the commanded kinematics at kinematic time psi / (f_trim + command_f), so the phase
//    is continuous when the frequency changes (as in flight/free_flight.cpp); without it the kinematic time is the
//    flow time.
#pragma once
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include "cfd/navier_stokes/free_body.hpp"
#include "cfd/navier_stokes/simulation.hpp"
#include "flight/controller.hpp"
#include "flight/dynamics.hpp"
#include "flight/free_flight.hpp"

namespace flapstab {

// A part of the body left the grid's uniform fine box.
class BodyLeftGrid : public SolveError {
 public:
  using SolveError::SolveError;
};

// A re-plan of the fine box (set_replanning).
struct CfdReplan {
  long step = 0;
  double time = 0;           // s
  ns::FineBoxShift shift;    // of the flight's first plan's fine box, in its fine cells
  Vec3 fine_lo = Vec3::Zero(), fine_hi = Vec3::Zero();  // the new fine box (m, grid axes)
  std::size_t cells = 0;     // of the new grid
  double gap = 0;            // the parts' smallest distance to a face of the old fine box when it was re-planned (m)
  double seconds = 0;        // wall time of the re-plan (new solver, carried-over flow)
};

// One coupled step.
struct CfdFlightStep {
  long step = 0;
  double time = 0;  // s, the kinematic (and flow) time
  double cfl = 0;
  BodyStateVector x = BodyStateVector::Zero();
  Wrench aero;       // fluid wrench at `time`, body axes, about O (pressure and viscous)
  Wrench buoyancy;   // of the closed parts, body axes, about O
  double power = 0;  // W: the parts' rate of work on the air (grid frame)
  std::vector<double> command;  // actuator offsets from trim (parameter units; one per dynamics actuator)
  double phase = 0;  // the wings' phase (wingbeats since t = 0 of the flow; time x trimmed frequency unless the
                     // frequency is an actuator)
};

class CfdFlight {
 public:
  // dynamics: the insect, its (trimmed) kinematics and the degrees of freedom (its own loads are not used);
  // plan: a plan in still air (plan_cfd with no body motion) for dynamics' kinematics; ranks: the MPI ranks the flow
  // runs over (its grid in z slabs, ns::Simulation's SimulationOptions::decomposition; null: one process). Over
  // several ranks every rank must make the same calls: the body's equations are integrated on every rank from rank
  // 0's loads (broadcast each step, so that no rank's body drifts from another's by the round-off of a reduction).
  CfdFlight(const Case& c, const FlightDynamics& dynamics, const ns::CfdPlan& plan,
            std::shared_ptr<const ns::Decomposition> ranks = {});
  ~CfdFlight();
  // Starts from a flow state (the kept periodic hover, tethered: computed with the body at rest at O) or from
  // rest (nullptr, the flow at t = 0), the body at x0 (the DoF set's held components zeroed).
  void start(const ns::SimulationState* flow, const BodyStateVector& x0);
  // One coupled step; throws ns::StepFailure (the flow) or BodyLeftGrid (after the step: the state is the
  // offending one, so a checkpoint can be written).
  CfdFlightStep advance();
  // The current step (loads at the current time).
  const CfdFlightStep& current() const { return cur_; }
  const ns::Simulation& simulation() const { return *sim_; }
  double body_mass() const;
  // Mass of the fluid the forcing holds solid: the closed parts' volumes and the membranes' slabs (area x 2 x 0.6
  // fine cells), times the fluid density (kg). Its ratio to body_mass() bounds the explicit coupling's lag: a
  // sphere with momentum-exchange loads was measured stable at a ratio of 0.1 and unstable at 0.5
  // (docs/theory/fluid-body-coupling.md).
  double forced_fluid_mass() const;
  // A constant wrench (body axes, about O) added to the fluid's in the body's equations (the residual of an
  // untrimmed hover cancelled; flapstab fly [flight] cfd_residual). Zero by default.
  void set_offset(const Wrench& w) { offset_ = w; }
  const Wrench& offset() const { return offset_; }
  // Exact continuation: the flow state, the body state and the fluid wrench held over the next step (the
  // current step's aero). Over ranks the whole grid's state on rank 0 (empty fields elsewhere; collective).
  ns::SimulationState flow_state() const { return sim_->whole_state(); }
  // flow: the whole grid's state (on every rank) or, over ranks, this rank's slab of it.
  // past: the flight's steps from its start to the restored one (their times and states; only with a controller:
  // its sensed history and filter states are replayed from them, so the continuation is exact). shift: the fine
  // box's shift the state was computed on (fine_box_shift() when it was taken); phase: the wings' phase then
  // (current().phase; needed only with the frequency as an actuator, default: time x trimmed frequency).
  void restore(const ns::SimulationState& flow, const BodyStateVector& x, const Wrench& aero,
               const std::vector<CfdFlightStep>& past = {}, const ns::FineBoxShift& shift = {},
               std::optional<double> phase = std::nullopt);

  // Re-plans the fine box around the body when a part has used half its room (see the coupling notes above); off
  // by default. Call before start or restore.
  void set_replanning(bool on) { replan_ = on; }
  // The current grid's plan and its fine box's shift from the plan the flight was built with.
  const ns::CfdPlan& plan() const { return plan_; }
  const ns::FineBoxShift& fine_box_shift() const { return shift_; }
  // The re-plans since start or restore.
  const std::vector<CfdReplan>& replans() const { return replans_; }
  // The room the fine box gives the swept volume (m): the smallest margin of the first plan.
  double room() const { return room_; }

  // Closes the loop (before start or restore): the controller's actuators must be the dynamics' (in its order or
  // not); reference(s) is the body state the sensors compare with at flight time s = t - t_start (s >= 0; before
  // the start the sensors see no deviation).
  void set_controller(const ControllerSpec& controller, std::function<BodyStateVector(double)> reference);
  bool closed_loop() const;
  // The command at time t with the body at x (actuator offsets from trim, parameter units).
  std::vector<double> command(double t, const BodyStateVector& x) const;

 private:
  class Feedback;
  CfdFlightStep observe(long step, double cfl) const;
  Wrench buoyancy(const BodyStateVector& x) const;
  // The body's equations with the wings at phase psi (used only with the frequency as an actuator).
  BodyStateVector rhs(double t, const BodyStateVector& x, double psi, const Wrench& held) const;
  // The body state and the wings' phase at time t in the current step (from the step's start with its loads held).
  std::pair<BodyStateVector, double> body_at(double t) const;
  // The kinematic time of the wings at time t, phase psi, under command cmd.
  double kinematic_time(double t, double psi, const std::vector<double>& cmd) const;
  std::vector<ns::PartState> parts_at(double t) const;
  // The parts' surfaces' extents at the current time (one evaluation of the parts' motion for all).
  std::vector<ns::BoundingBox> part_boxes() const;
  void check_inside(const std::vector<ns::BoundingBox>& boxes) const;
  // The parts' smallest distance to a face of the fine box (m; negative: outside).
  double gap(const std::vector<ns::BoundingBox>& boxes) const;
  // Re-plans when the parts are closer than room_ / 2 to the fine box (replan_).
  void maybe_replan(const std::vector<ns::BoundingBox>& boxes);
  // The re-plan's check and the fine box's check after a step or a start.
  void check_room();
  // A new simulation on the first plan's fine box shifted by `shift` (plan_, shift_ updated; no flow restored).
  void rebuild(const ns::FineBoxShift& shift);
  const FlightDynamics& dyn_;
  Case case_;
  std::shared_ptr<const ns::Decomposition> ranks_;  // null: one process
  ns::CfdPlan base_plan_;
  ns::FineBoxShift shift_;
  bool replan_ = false;
  double room_ = 0;
  std::vector<CfdReplan> replans_;
  std::unique_ptr<ns::Simulation> sim_;
  std::vector<double> volume_;
  std::vector<Vec3> centroid_;
  double rho_ = 0, g_ = 0;
  ns::CfdPlan plan_;
  int freq_ = -1;    // the frequency's index among the dynamics' actuators (-1: not an actuator)
  double f0_ = 0;    // the trimmed frequency (Hz)
  double psi_ = 0, base_psi_ = 0;  // the wings' phase (cycles) now and at the step's start
  BodyStateVector x_ = BodyStateVector::Zero();
  CfdFlightStep cur_;
  // The current step's start: time, body state, fluid wrench held over the step.
  double base_time_ = 0;
  BodyStateVector base_x_ = BodyStateVector::Zero();
  Wrench base_aero_;
  Wrench offset_;
  std::unique_ptr<Feedback> feedback_;
  // The wing parts relative to the body for a command (the prescribed ones without).
  std::vector<ns::PartState> relative_parts(double t, const std::vector<double>& command) const;
};

}  // namespace flapstab
