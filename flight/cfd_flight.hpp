// Free flight coupled to the Navier-Stokes solver: the body's equations (flight/dynamics.hpp) advanced with the
// loads of the immersed-boundary CFD, the body's parts moved through the grid by the body state and the wing
// kinematics.
//
// Coupling (docs/theory/fluid-body-coupling.md):
//  - The grid is fixed in space (the inertial axes of the body state, z down; at the zero state the body's
//    stability axes and O coincide with the grid's): the far field is still air, the momentum equation has no frame
//    terms, and the body moves through the uniform fine box, which must hold it: a part that leaves the fine box
//    stops the run (BodyLeftGrid) so that the driver can write a checkpoint. [aero.cfd] fine_margin_R sets the room.
//  - Explicit, loosely coupled: over the step t_n -> t_n+1 the body's equations are integrated with the fluid's
//    wrench at t_n held (classical Runge-Kutta, two sub-steps from t_n to each Runge-Kutta stage time of the fluid,
//    so each stage sees the body where the held loads put it, with its analytic velocity and acceleration). The
//    lag acts on the body's own acceleration reaction: a lagged added mass m_a makes the step map of the body's
//    acceleration a_n+1 = -(m_a / m) a_n + ..., stable for m_a < m. For a hawkmoth in air m_a / m is
//    estimated at 0.005-0.02 (the fluid its forcing holds solid on 8 cells per chord: 0.0056 of its mass,
//    forced_fluid_mass()); a sphere has m_a / m = rho_f / (2 rho_s) in potential flow.
//  - Gravity acts on the insect's mass (its equations), buoyancy rho_f V g on its closed parts (the solver's
//    pressure carries no hydrostatics), at their centroids.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include "cfd/navier_stokes/free_body.hpp"
#include "cfd/navier_stokes/simulation.hpp"
#include "flight/dynamics.hpp"
#include "flight/free_flight.hpp"

namespace flapstab {

// A part of the body left the grid's uniform fine box.
class BodyLeftGrid : public SolveError {
 public:
  using SolveError::SolveError;
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
};

class CfdFlight {
 public:
  // dynamics: the insect, its (trimmed) kinematics and the degrees of freedom (its own loads are not used);
  // plan: a plan in still air (plan_cfd with no body motion) for dynamics' kinematics.
  CfdFlight(const Case& c, const FlightDynamics& dynamics, const ns::CfdPlan& plan);
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
  // current step's aero).
  ns::SimulationState flow_state() const { return sim_->state(); }
  void restore(const ns::SimulationState& flow, const BodyStateVector& x, const Wrench& aero);

 private:
  CfdFlightStep observe(long step, double cfl) const;
  Wrench buoyancy(const BodyStateVector& x) const;
  BodyStateVector rhs(double t, const BodyStateVector& x, const Wrench& held) const;
  // The body state at time t in the current step (from the step's start with its loads held).
  BodyStateVector body_at(double t) const;
  std::vector<ns::PartState> parts_at(double t) const;
  void check_inside() const;
  const FlightDynamics& dyn_;
  std::unique_ptr<ns::Simulation> sim_;
  std::vector<double> volume_;
  std::vector<Vec3> centroid_;
  double rho_ = 0, g_ = 0;
  ns::CfdPlan plan_;
  BodyStateVector x_ = BodyStateVector::Zero();
  CfdFlightStep cur_;
  // The current step's start: time, body state, fluid wrench held over the step.
  double base_time_ = 0;
  BodyStateVector base_x_ = BodyStateVector::Zero();
  Wrench base_aero_;
  Wrench offset_;
};

}  // namespace flapstab
