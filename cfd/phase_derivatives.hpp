// Phase-resolved (time-periodic) derivatives: the free body-plus-wings system linearised about a periodic orbit.
//
// At each phase t_k of the wingbeat the instantaneous aerodynamic wrench W(t, v, w) about O is
// differentiated by central differences in u, v, w, p, q, r about the orbit's own body motion (steps
// h U and h U / c, h the case's relative step, as for the cycle-averaged derivatives), and combined with
// the linearised equations of motion (core/eom.hpp) into A(t_k) = d f / d x for the states
// [u, v, w, p, q, r, phi, theta] (SI: m/s, rad/s, rad; time in s). Position and psi are neutral and
// left out. Theory and state order: docs/theory/floquet.md.
#pragma once
#include <memory>
#include <vector>
#include "cfd/quasi_steady/quasi_steady.hpp"
#include "core/aero_model.hpp"
#include "core/derivative_table.hpp"
#include "core/eom.hpp"

namespace flapstab {

// The instantaneous loads of an AeroModel for one insect and kinematics, built once (the quasi-steady
// model's fast path reuses its Configuration and span quadrature). Throws InputError when the model
// has no instantaneous form (CFD).
class InstantaneousAero {
 public:
  InstantaneousAero(const AeroModel& model, const Insect& insect, const Kinematics& kin);
  InstantaneousAero(const InstantaneousAero&) = delete;
  InstantaneousAero& operator=(const InstantaneousAero&) = delete;
  // Total aerodynamic wrench about O, stability axes, at time t for the body motion.
  Wrench operator()(double t, const BodyMotion& motion) const;
  const Configuration& configuration() const { return *config_; }
  const Kinematics& kinematics() const { return kin_; }
  const Insect& insect() const { return insect_; }
  long evaluations() const { return evaluations_; }

 private:
  const AeroModel& model_;
  const QuasiSteadyModel* qs_ = nullptr;
  Insect insect_;
  Kinematics kin_;
  std::unique_ptr<Configuration> config_;
  SpanQuadrature span_;
  mutable long evaluations_ = 0;
};

// Body motion (velocity and rates) of a body state: the aerodynamic model's input.
BodyMotion body_motion(const BodyStateVector& x);

// dx/dt of the free body-plus-wings system with the instantaneous aerodynamic loads.
// g defaults to the insect's gravity here and below.
BodyStateVector free_flight_derivative(const InstantaneousAero& aero, double t, const BodyStateVector& x,
                                       std::optional<double> g = std::nullopt);

// Index of each state of [u, v, w, p, q, r, phi, theta] in BodyStateVector.
inline constexpr int linear_state_index[8] = {3, 4, 5, 6, 7, 8, 9, 10};
const std::vector<std::string>& linear_state_names();  // {"u","v","w","p","q","r","phi","theta"}

struct PhaseSample {
  double time = 0;                          // s
  BodyStateVector state;                    // orbit state at this phase
  Eigen::Matrix<double, 6, 6> wrench_si;    // d[X Y Z L M N] / d[u v w p q r] (N per m/s, N m per rad/s, ...)
  Eigen::Matrix<double, 6, 6> wrench_nd;    // the same, non-dimensional (as DerivativeTable::nd)
  // d[X Y Z L M N] / d[phi theta] (N, N m per rad) of the aerodynamic wrench alone: zero for a model without memory
  // (in still air a steady attitude changes nothing); measured by the forced pitch oscillation (theta column).
  Eigen::Matrix<double, 6, 2> attitude_si = Eigen::Matrix<double, 6, 2>::Zero();
  Eigen::Matrix<double, 8, 8> system_si;    // A(t) for [u v w p q r phi theta], 1/s
};

struct PhaseDerivatives {
  double period = 0;                        // s
  double relative_step = 0, velocity_step = 0, rate_step = 0;
  ReferenceQuantities reference;
  std::vector<PhaseSample> samples;         // at t_k = k T / N, k = 0..N-1
  long load_evaluations = 0;
  // Cycle means of wrench_si and wrench_nd (about the rest state they are the averaged derivatives).
  Eigen::Matrix<double, 6, 6> mean_wrench_si() const;
  Eigen::Matrix<double, 6, 6> mean_wrench_nd() const;
  // A(t_k) restricted to the named subset of [u v w p q r phi theta], e.g. {0, 2, 4, 7} = [u w q theta].
  std::vector<Eigen::MatrixXd> system_samples(const std::vector<int>& states) const;
};

// Completes a sample whose time, state and wrench_si (and attitude_si) are set: wrench_nd, and system_si = the
// linearised equations of motion at (time, state) with the aerodynamic wrench held at w0, plus the mass matrix's
// response to wrench_si and attitude_si.
void complete_phase_sample(PhaseSample& s, const Configuration& config, const Wrench& w0,
                           const ReferenceQuantities& reference, std::optional<double> g = std::nullopt);

// Linearisation of the free system at N phases about a periodic orbit given by its states at
// t_k = k T / N (orbit.size() = N; an orbit of zeros is hover at rest with the body held still).
PhaseDerivatives phase_resolved_derivatives(const InstantaneousAero& aero, const std::vector<BodyStateVector>& orbit,
                                            const ReferenceQuantities& reference, double relative_step,
                                            std::optional<double> g = std::nullopt);

}  // namespace flapstab
