// The hover's linear models for flight control, computed once.
#include "flight/hover_model.hpp"

#include <chrono>
#include <fmt/format.h>
#include "core/errors.hpp"
#include "core/rotation.hpp"
#include "flight/free_flight.hpp"
#include "stability/floquet.hpp"

namespace flapstab {

HoverModel hover_model(const Case& c, const AeroModel& model, const std::vector<TrimParameterSpec>& actuators,
                       int phases, const CyclicTrimOptions& cyclic, const TrimResult* averaged) {
  const auto t0 = std::chrono::steady_clock::now();
  check_cyclic_trim_case(c, model);
  HoverModel h;
  h.averaged_trim = averaged ? *averaged : trim_hover(c, model);
  if (!h.averaged_trim.converged)
    throw SolveError(fmt::format("{}: the averaged trim did not converge ({})", c.path, h.averaged_trim.message));
  h.cyclic = cyclic_trim(c, model, h.averaged_trim, cyclic);
  if (!h.cyclic.converged)
    throw SolveError(fmt::format("{}: cyclic trim did not converge ({}); periodicity residual {:.2e}", c.path,
                                 h.cyclic.message, h.cyclic.residual));
  const Kinematics& kin = h.cyclic.kinematics;
  h.derivatives = cycle_averaged_derivatives(model, c.insect, kin, c.fluid, c.derivatives.relative_step);
  const ReferenceQuantities& ref = h.derivatives.table.reference;
  h.control = control_derivatives(model, c.insect, kin, actuators, ref);
  h.derivatives.table.control = h.control.columns;
  const int N = phases > 0 ? phases : c.aero.quasi_steady.samples_per_cycle;
  const InstantaneousAero aero(model, c.insect, kin);
  h.orbit = periodic_orbit(aero, h.cyclic.initial_state, N);
  h.phase = phase_resolved_derivatives(aero, h.orbit, ref, c.derivatives.relative_step);
  h.longitudinal = averaged_plant(longitudinal_system(h.derivatives.table), ref);
  h.lateral = averaged_plant(lateral_system(h.derivatives.table), ref);
  h.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return h;
}

BodyStateVector floquet_mode_perturbation(const HoverModel& h, const std::string& subsystem, double amplitude,
                                          std::complex<double>* multiplier) {
  const bool lon = subsystem == "longitudinal";
  const std::vector<int> idx = lon ? std::vector<int>{0, 2, 4, 7} : std::vector<int>{1, 3, 5, 6};
  const std::vector<std::string> names = lon ? std::vector<std::string>{"u", "w", "q", "theta"}
                                             : std::vector<std::string>{"v", "p", "r", "phi"};
  Eigen::MatrixXd M(4, 4);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) M(i, j) = h.cyclic.monodromy(idx[std::size_t(i)], idx[std::size_t(j)]);
  const Eigen::EigenSolver<Eigen::MatrixXd> es(M);
  int k = 0;
  for (int i = 1; i < 4; ++i)
    if (std::abs(es.eigenvalues()(i)) > std::abs(es.eigenvalues()(k))) k = i;
  if (multiplier) *multiplier = es.eigenvalues()(k);
  const Eigen::VectorXd scale = nondimensional_state_scale(names, h.derivatives.table.reference);
  Eigen::VectorXd v = es.eigenvectors().col(k).real();
  if (v.cwiseAbs().maxCoeff() == 0) v = es.eigenvectors().col(k).imag();
  v *= amplitude / (scale.asDiagonal() * v).cwiseAbs().maxCoeff();
  BodyStateVector d = BodyStateVector::Zero();
  for (int i = 0; i < 4; ++i) d(linear_state_index[idx[std::size_t(i)]]) = v(i);
  return d;
}

ControlSummary pitch_control_summary(const Case& c, const AeroModel& model, const CyclicTrimResult& cyclic,
                                     const DerivativeResult& derivatives, const PhaseDerivatives& phase) {
  if (c.control.type != "pitch") throw InputError(c.path, "control.type", "no pitch controller", "type = \"pitch\"");
  ControlSummary s;
  const Kinematics& kin = cyclic.kinematics;
  s.period = kin.period();
  const TrimParameterSpec a = unbounded_parameter(c.control.actuator);
  const double trim = parameter_value(kin, c.control.actuator, c.path);
  DerivativeTable table = derivatives.table;
  s.control = control_derivatives(model, c.insect, kin, {a}, table.reference);
  table.control = s.control.columns;
  s.neutral = neutral_axis(table);
  const LinearPlant plant = averaged_plant(longitudinal_system(table), table.reference);
  const PitchControllerSettings base = pitch_controller_settings(c.control);
  const ControllerSpec own = pitch_controller(base, trim);
  s.description = own.description;
  const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(plant.A).eigenvalues();
  s.open_abscissa = -INFINITY;
  for (Eigen::Index i = 0; i < ev.size(); ++i) s.open_abscissa = std::max(s.open_abscissa, ev(i).real());
  s.closed_abscissa = rightmost_roots(closed_loop(plant, own, c.path, "control.pitch")).spectral_abscissa();
  const FlightDynamics dyn(model, c.insect, kin, own.actuators, DofSet::longitudinal);
  const PeriodicPlant pp = periodic_plant(dyn, phase, {"u", "w", "q", "theta"});
  s.closed_radius = delayed_floquet(closed_loop(pp, own, c.path, "control.pitch")).spectral_radius();
  s.open_radius = delayed_floquet(closed_loop(pp, ControllerSpec{}, c.path, "control.pitch")).spectral_radius();
  s.latency_max = c.control.map_latency_max_s > 0 ? c.control.map_latency_max_s : 3 * s.period;
  const DelaySystemBuilder build = [&](double g, double tau) {
    return closed_loop(plant, controller_at(base, MapGain::pitch, g, tau, trim), c.path, "control.pitch");
  };
  s.critical = critical_latency(build, base.pitch_gain, s.latency_max);
  s.best = best_gain(build, c.control.map_gain_min, c.control.map_gain_max, s.latency_max);
  return s;
}

std::vector<ComSweepPoint> com_height_sweep(const Case& c, const AeroModel& model, const std::vector<double>& dz,
                                            double wingbeats) {
  std::vector<ComSweepPoint> out;
  for (double d : dz) {
    Case m = c;
    // Hinges up by d relative to the body CoM (S axes, z down), i.e. the CoM d lower below the wings.
    m.insect.wing.hinge -= rot_y(c.kinematics.body_angle).transpose() * Vec3(0, 0, d);
    CyclicTrimOptions co;
    co.tolerance = 1e-8;
    const HoverModel h = hover_model(m, model, {}, 0, co);
    const double T = h.cyclic.period;
    ComSweepPoint p;
    p.dz = d;
    p.com_below_axis_m = neutral_axis(h.derivatives.table).com_below_axis_m;
    const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(h.longitudinal.A).eigenvalues();
    Eigen::Index k = 0;
    for (Eigen::Index i = 1; i < ev.size(); ++i)
      if (ev(i).real() > ev(k).real()) k = i;
    p.lti_growth = ev(k).real() * T;
    p.lti_oscillatory = std::abs(ev(k).imag()) > 0;
    std::complex<double> mu;
    floquet_mode_perturbation(h, "longitudinal", 1e-3, &mu);
    p.floquet_growth = std::log(std::abs(mu));
    const FlightDynamics dyn(model, m.insect, h.cyclic.kinematics, {}, DofSet::longitudinal);
    BodyStateVector x0 = h.cyclic.initial_state;
    x0(10) += 0.5 * deg;
    FlightOptions fo;
    fo.wingbeats = wingbeats;
    fo.samples_per_wingbeat = 40;
    const ReferenceOrbit ref = reference_orbit(h.orbit, T);
    const FlightResult r = simulate_flight(dyn, ControllerSpec{}, x0, ref, h.derivatives.table.reference, fo);
    p.simulated_growth = r.completed ? wingbeat_growth(r, ref, h.derivatives.table.reference, T, {3, 5, 7, 10}).per_wingbeat
                                     : INFINITY;
    out.push_back(p);
  }
  return out;
}

}  // namespace flapstab
