// The free body with its wings as a dynamical system: loads from an instantaneous AeroModel, Newton-Euler
// equations (core/eom.hpp), degrees of freedom selectable, kinematic parameters as actuator inputs.
//
// The reference point O stays where the trimmed kinematics put it (their wingbeat-mean CoM) whatever the
// actuators do: a controller that tilts the stroke plane moves the wings' mass, and so the CoM, relative to O,
// and the equations (which hold for any first mass moment c(t)) carry that through gravity and inertia.
// Actuator changes enter the wing kinematics as parameters; their own rate of change is not added to the wing
// velocities (the commands vary slowly against the wingbeat; docs/theory/flight-control.md).
#pragma once
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>
#include "cfd/quasi_steady/quasi_steady.hpp"
#include "core/aero_model.hpp"
#include "core/body_state.hpp"
#include "trim/parameters.hpp"

namespace flapstab {

// Which body degrees of freedom move. The velocity and rate components of the others are held at zero (the
// simulation zeroes them in the initial state), so their positions and angles stay at their initial values.
enum class DofSet {
  six_dof,       // all of u v w p q r
  longitudinal,  // u, w, q (x, z, theta)
  pitch,         // q only (theta), O held fixed
  translation,   // u, v, w; attitude held at its initial value (p = q = r = 0)
};
// "6dof" | "longitudinal" | "pitch" | "translation"; InputError(file, key) otherwise.
DofSet parse_dof_set(const std::string& name, const std::string& file, const std::string& key);
std::string dof_set_name(DofSet d);
// Free entries of [u' v' w' p' q' r'].
std::array<bool, 6> free_accelerations(DofSet d);
const std::vector<std::string>& dof_set_names();

struct FlightDerivative {
  BodyStateVector dx;
  Wrench aero;       // about O, body axes
  double power = 0;  // aerodynamic power (W)
};

class FlightDynamics {
 public:
  // actuators: the kinematic parameters a controller may change (TrimParameterization names; may be empty).
  // aerodynamics = false drops the aerodynamic loads (conservation tests).
  FlightDynamics(const AeroModel& model, const Insect& insect, const Kinematics& trimmed,
                 std::vector<TrimParameterSpec> actuators, DofSet dofs,
                 std::optional<double> gravity = std::nullopt,  // default: insect.gravity
                 bool aerodynamics = true, const std::string& file = "");
  FlightDynamics(const FlightDynamics&) = delete;
  FlightDynamics& operator=(const FlightDynamics&) = delete;

  // dx/dt with the wings at kinematic time t_kin (phase t_kin * frequency) and the actuators offset by
  // `command` from their trimmed values (parameter units: deg or Hz; empty = no offset).
  FlightDerivative derivative(double t_kin, const BodyStateVector& x, const std::vector<double>& command) const;
  // The same with the aerodynamic wrench about O (body axes) given, not computed: a load model with memory (the
  // Navier-Stokes solver coupled step by step, flight/cfd_flight.hpp) supplies it. power is copied through.
  FlightDerivative derivative(double t_kin, const BodyStateVector& x, const std::vector<double>& command,
                              const Wrench& aero, double power = 0) const;
  // x with the velocity and rate components that the DoF set holds set to zero.
  BodyStateVector held(const BodyStateVector& x) const;
  // The kinematics with the actuators offset by command.
  Kinematics kinematics(const std::vector<double>& command) const;
  const Kinematics& trimmed() const { return trimmed_; }
  const Insect& insect() const { return insect_; }
  const Configuration& configuration() const { return *config_; }  // trimmed kinematics, O fixed
  const std::vector<TrimParameterSpec>& actuators() const { return par_.specs(); }
  std::optional<int> actuator_index(const std::string& name) const;
  // Trimmed value of each actuator (parameter units).
  const std::vector<double>& actuator_trim() const { return par_.initial(); }
  DofSet dofs() const { return dofs_; }
  double gravity() const { return g_; }
  long evaluations() const { return evaluations_; }

 private:
  Wrench loads(const Configuration& cfg, const Kinematics& kin, double t, const BodyStateVector& x,
               double& power) const;
  FlightDerivative equations(const Configuration& cfg, double t, const BodyStateVector& x, const Wrench& aero,
                             double power) const;
  const AeroModel& model_;
  const QuasiSteadyModel* qs_ = nullptr;
  Insect insect_;
  Kinematics trimmed_;
  TrimParameterization par_;
  DofSet dofs_;
  double g_;
  bool aero_;
  std::unique_ptr<Configuration> config_;
  SpanQuadrature span_;
  mutable long evaluations_ = 0;
};

}  // namespace flapstab
