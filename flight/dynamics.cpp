// Free-flight right-hand side: constrained Newton-Euler equations with instantaneous loads and actuated kinematics.
#include "flight/dynamics.hpp"

#include <cmath>
#include "core/errors.hpp"
#include "core/rotation.hpp"

namespace flapstab {

const std::vector<std::string>& dof_set_names() {
  static const std::vector<std::string> names{"6dof", "longitudinal", "pitch", "translation"};
  return names;
}

DofSet parse_dof_set(const std::string& name, const std::string& file, const std::string& key) {
  if (name == "6dof") return DofSet::six_dof;
  if (name == "longitudinal") return DofSet::longitudinal;
  if (name == "pitch") return DofSet::pitch;
  if (name == "translation") return DofSet::translation;
  throw InputError(file, key, "unknown degree-of-freedom set \"" + name + "\"",
                   "\"6dof\", \"longitudinal\", \"pitch\" or \"translation\"");
}

std::string dof_set_name(DofSet d) { return dof_set_names()[std::size_t(d)]; }

std::array<bool, 6> free_accelerations(DofSet d) {
  switch (d) {
    case DofSet::six_dof: return {true, true, true, true, true, true};
    case DofSet::longitudinal: return {true, false, true, false, true, false};
    case DofSet::pitch: return {false, false, false, false, true, false};
    case DofSet::translation: return {true, true, true, false, false, false};
  }
  return {};
}

FlightDynamics::FlightDynamics(const AeroModel& model, const Insect& insect, const Kinematics& trimmed,
                               std::vector<TrimParameterSpec> actuators, DofSet dofs, std::optional<double> gravity,
                               bool aerodynamics, const std::string& file)
    : model_(model), insect_(insect), trimmed_(trimmed), par_(trimmed, std::move(actuators), file), dofs_(dofs),
      g_(gravity.value_or(insect.gravity)), aero_(aerodynamics) {
  if (aero_ && !model.is_instantaneous())
    throw InputError(file, "aero.model",
                     "the " + model.name() + " model has no instantaneous loads, which free flight needs here",
                     "model = \"quasi-steady\"");
  qs_ = dynamic_cast<const QuasiSteadyModel*>(&model);
  config_ = std::make_unique<Configuration>(insect_, trimmed_);
  if (qs_) span_ = span_quadrature(insect_, qs_->options().blade_elements);
}

std::optional<int> FlightDynamics::actuator_index(const std::string& name) const {
  for (std::size_t i = 0; i < par_.specs().size(); ++i)
    if (par_.specs()[i].label() == name) return int(i);
  return std::nullopt;
}

BodyStateVector FlightDynamics::held(const BodyStateVector& x) const {
  BodyStateVector y = x;
  const std::array<bool, 6> free = free_accelerations(dofs_);
  for (int i = 0; i < 6; ++i)
    if (!free[std::size_t(i)]) y(3 + i) = 0;
  return y;
}

Kinematics FlightDynamics::kinematics(const std::vector<double>& command) const {
  std::vector<double> v = par_.initial();
  for (std::size_t i = 0; i < command.size() && i < v.size(); ++i) v[i] += command[i];
  return par_.apply(v);
}

Wrench FlightDynamics::loads(const Configuration& cfg, const Kinematics& kin, double t, const BodyStateVector& x,
                             double& power) const {
  power = 0;
  if (!aero_) return Wrench{};
  BodyMotion m;
  m.velocity = x.segment<3>(3);
  m.rate = x.segment<3>(6);
  if (qs_) {
    const WrenchSample s = qs_->loads(cfg, span_, t, m);
    power = s.power;
    return s.total();
  }
  // Another instantaneous model reports moments about its own O: move them to the fixed one.
  const WrenchSample s = model_.instantaneous(insect_, kin, t, m);
  power = s.power;
  Wrench w = s.total();
  const Vec3 o_model = Configuration(insect_, kin).reference_point();
  w.moment += (o_model - cfg.reference_point()).cross(w.force);
  return w;
}

FlightDerivative FlightDynamics::derivative(double t, const BodyStateVector& x,
                                            const std::vector<double>& command) const {
  ++evaluations_;
  bool actuated = false;
  for (double c : command) actuated = actuated || c != 0;
  std::optional<Kinematics> kin;
  std::optional<Configuration> cfg_actuated;
  if (actuated) {
    kin = kinematics(command);
    cfg_actuated.emplace(insect_, *kin, config_->reference_point());
  }
  const Configuration& cfg = actuated ? *cfg_actuated : *config_;
  double power = 0;
  const Wrench aero = loads(cfg, actuated ? *kin : trimmed_, t, x, power);
  return equations(cfg, t, x, aero, power);
}

FlightDerivative FlightDynamics::derivative(double t, const BodyStateVector& x, const std::vector<double>& command,
                                            const Wrench& aero, double power) const {
  ++evaluations_;
  bool actuated = false;
  for (double c : command) actuated = actuated || c != 0;
  if (!actuated) return equations(*config_, t, x, aero, power);
  const Kinematics kin = kinematics(command);
  const Configuration cfg(insect_, kin, config_->reference_point());
  return equations(cfg, t, x, aero, power);
}

FlightDerivative FlightDynamics::equations(const Configuration& cfg, double t, const BodyStateVector& x,
                                           const Wrench& aero, double power) const {
  FlightDerivative out;
  out.aero = aero;
  out.power = power;
  const EomTerms e = eom_terms(cfg.mass_state(t), x, out.aero, g_);
  // Constrained accelerations are zero: solve the free rows of M a = rhs for the free entries of a.
  const std::array<bool, 6> free = free_accelerations(dofs_);
  int idx[6], n = 0;
  for (int i = 0; i < 6; ++i)
    if (free[std::size_t(i)]) idx[n++] = i;
  Eigen::Matrix<double, 6, 1> acc = Eigen::Matrix<double, 6, 1>::Zero();
  if (n == 6) {
    acc = e.mass_matrix.partialPivLu().solve(e.rhs);
  } else {
    Eigen::MatrixXd Mf(n, n);
    Eigen::VectorXd rf(n);
    for (int i = 0; i < n; ++i) {
      rf(i) = e.rhs(idx[i]);
      for (int j = 0; j < n; ++j) Mf(i, j) = e.mass_matrix(idx[i], idx[j]);
    }
    const Eigen::VectorXd af = Mf.partialPivLu().solve(rf);
    for (int i = 0; i < n; ++i) acc(idx[i]) = af(i);
  }
  const double phi = x(9), theta = x(10);
  const Vec3 w = x.segment<3>(6);
  out.dx.segment<3>(0) = euler321(x(9), x(10), x(11)) * x.segment<3>(3);
  out.dx.segment<6>(3) = acc;
  const double sp = std::sin(phi), cp = std::cos(phi), ct = std::cos(theta), tt = std::tan(theta);
  out.dx(9) = w.x() + (w.y() * sp + w.z() * cp) * tt;
  out.dx(10) = w.y() * cp - w.z() * sp;
  out.dx(11) = (w.y() * sp + w.z() * cp) / ct;
  return out;
}

}  // namespace flapstab
