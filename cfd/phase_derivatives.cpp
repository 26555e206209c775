// Phase-resolved derivatives: instantaneous wrench derivatives and the linearised EoM along a periodic orbit.
#include "cfd/phase_derivatives.hpp"

#include "core/errors.hpp"

namespace flapstab {

InstantaneousAero::InstantaneousAero(const AeroModel& model, const Insect& insect, const Kinematics& kin)
    : model_(model), insect_(insect), kin_(kin) {
  if (!model.is_instantaneous())
    throw InputError("", "aero.model",
                     "the " + model.name() + " model has no instantaneous loads, which the periodic (Floquet) analysis needs",
                     "model = \"quasi-steady\"");
  qs_ = dynamic_cast<const QuasiSteadyModel*>(&model);
  config_ = std::make_unique<Configuration>(insect_, kin_);
  if (qs_) span_ = span_quadrature(insect_, qs_->options().blade_elements);
}

Wrench InstantaneousAero::operator()(double t, const BodyMotion& motion) const {
  ++evaluations_;
  if (qs_) return qs_->loads(*config_, span_, t, motion).total();
  return model_.instantaneous(insect_, kin_, t, motion).total();
}

BodyMotion body_motion(const BodyStateVector& x) {
  BodyMotion m;
  m.velocity = x.segment<3>(3);
  m.rate = x.segment<3>(6);
  return m;
}

BodyStateVector free_flight_derivative(const InstantaneousAero& aero, double t, const BodyStateVector& x,
                                       std::optional<double> g) {
  return body_state_derivative(aero.configuration(), t, x, aero(t, body_motion(x)), g);
}

const std::vector<std::string>& linear_state_names() {
  static const std::vector<std::string> names{"u", "v", "w", "p", "q", "r", "phi", "theta"};
  return names;
}

Eigen::Matrix<double, 6, 6> PhaseDerivatives::mean_wrench_si() const {
  Eigen::Matrix<double, 6, 6> m = Eigen::Matrix<double, 6, 6>::Zero();
  for (const auto& s : samples) m += s.wrench_si;
  return m / double(samples.size());
}

Eigen::Matrix<double, 6, 6> PhaseDerivatives::mean_wrench_nd() const {
  Eigen::Matrix<double, 6, 6> m = Eigen::Matrix<double, 6, 6>::Zero();
  for (const auto& s : samples) m += s.wrench_nd;
  return m / double(samples.size());
}

std::vector<Eigen::MatrixXd> PhaseDerivatives::system_samples(const std::vector<int>& states) const {
  const Eigen::Index n = Eigen::Index(states.size());
  std::vector<Eigen::MatrixXd> out;
  for (const auto& s : samples) {
    Eigen::MatrixXd A(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j) A(i, j) = s.system_si(states[std::size_t(i)], states[std::size_t(j)]);
    out.push_back(A);
  }
  return out;
}

void complete_phase_sample(PhaseSample& s, const Configuration& config, const Wrench& w0,
                           const ReferenceQuantities& ref, std::optional<double> g_given) {
  const double g = g_given.value_or(config.insect().gravity);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      s.wrench_nd(i, j) = s.wrench_si(i, j) * (j < 3 ? ref.U : ref.U / ref.c) /
                          (i < 3 ? ref.force_scale() : ref.moment_scale());
  // Inertial part: d f / d x with the wrench held at w0. The EoM are quadratic in the velocities and
  // rates (central differences exact to rounding) and smooth in the angles; steps 1e-6 of the scales.
  const double hv = 1e-6 * ref.U, hw = 1e-6 * ref.U / ref.c, ha = 1e-6;
  for (int j = 0; j < 8; ++j) {
    const int idx = linear_state_index[j];
    const double h = j < 3 ? hv : (j < 6 ? hw : ha);
    BodyStateVector xp = s.state, xm = s.state;
    xp(idx) += h;
    xm(idx) -= h;
    const BodyStateVector d =
        (body_state_derivative(config, s.time, xp, w0, g) - body_state_derivative(config, s.time, xm, w0, g)) / (2 * h);
    s.system_si.col(j) = d.segment<8>(3);
  }
  // Aerodynamic coupling: the accelerations respond to the wrench through the inverse mass matrix
  // (eom_terms' right-hand side holds the wrench with unit coefficient).
  const EomTerms e = eom_terms(config.mass_state(s.time), s.state, w0, g);
  const auto lu = e.mass_matrix.partialPivLu();
  s.system_si.block<6, 6>(0, 0) += lu.solve(s.wrench_si);
  s.system_si.block<6, 2>(0, 6) += lu.solve(s.attitude_si);
}

PhaseDerivatives phase_resolved_derivatives(const InstantaneousAero& aero, const std::vector<BodyStateVector>& orbit,
                                            const ReferenceQuantities& ref, double relative_step,
                                            std::optional<double> g_given) {
  const double g = g_given.value_or(aero.configuration().insect().gravity);
  if (orbit.size() < 3) throw SolveError("phase_resolved_derivatives: need at least 3 phases");
  if (!(relative_step > 0)) throw SolveError("phase_resolved_derivatives: the relative step must be positive");
  const long evals0 = aero.evaluations();
  PhaseDerivatives out;
  out.period = aero.kinematics().period();
  out.relative_step = relative_step;
  out.velocity_step = relative_step * ref.U;
  out.rate_step = relative_step * ref.U / ref.c;
  out.reference = ref;
  const int N = static_cast<int>(orbit.size());
  const Configuration& config = aero.configuration();
  for (int k = 0; k < N; ++k) {
    PhaseSample s;
    s.time = out.period * k / N;
    s.state = orbit[std::size_t(k)];
    const BodyMotion m0 = body_motion(s.state);
    const Wrench w0 = aero(s.time, m0);
    // Aerodynamic part: central differences of the instantaneous wrench (the averaged derivatives' steps).
    for (int j = 0; j < 6; ++j) {
      const double h = j < 3 ? out.velocity_step : out.rate_step;
      BodyMotion plus = m0, minus = m0;
      (j < 3 ? plus.velocity : plus.rate)(j % 3) += h;
      (j < 3 ? minus.velocity : minus.rate)(j % 3) -= h;
      const Wrench wp = aero(s.time, plus), wm = aero(s.time, minus);
      s.wrench_si.col(j).head<3>() = (wp.force - wm.force) / (2 * h);
      s.wrench_si.col(j).tail<3>() = (wp.moment - wm.moment) / (2 * h);
    }
    complete_phase_sample(s, config, w0, ref, g);
    out.samples.push_back(s);
  }
  out.load_evaluations = aero.evaluations() - evals0;
  return out;
}

}  // namespace flapstab
