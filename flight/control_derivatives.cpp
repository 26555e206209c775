// Control derivatives by central differences of the cycle-mean wrench, moments about the trimmed O.
#include "flight/control_derivatives.hpp"
#include <algorithm>

#include "core/configuration.hpp"
#include "flight/controller.hpp"
#include "trim/parameters.hpp"

namespace flapstab {

ControlDerivativeResult control_derivatives(const AeroModel& model, const Insect& insect, const Kinematics& trimmed,
                                            const std::vector<TrimParameterSpec>& parameters,
                                            const ReferenceQuantities& ref, std::optional<double> g_given,
                                            const AeroRunOptions& run) {
  const double g = g_given.value_or(insect.gravity);
  const TrimParameterization par(trimmed, parameters, "");
  const Vec3 o_trim = Configuration(insect, trimmed).reference_point();
  const double mg = insect.total_mass() * g;
  ControlDerivativeResult out;
  const Eigen::Index n = Eigen::Index(parameters.size());
  out.si = Eigen::MatrixXd::Zero(6, n);
  out.gravity_si = Eigen::MatrixXd::Zero(6, n);
  // Mean wrench about the trimmed O, and the gravitational moment there, for a kinematics.
  auto about_trim = [&](const Kinematics& k, Eigen::Matrix<double, 6, 1>& grav) {
    const Wrench w = model.run(insect, k, BodyMotion{}, run).mean();
    ++out.model_runs;
    const Vec3 d = Configuration(insect, k).reference_point() - o_trim;  // mean CoM relative to the trimmed O
    Eigen::Matrix<double, 6, 1> v;
    v << w.force, w.moment + d.cross(w.force);
    grav.setZero();
    grav.tail<3>() = d.cross(Vec3(0, 0, mg));
    return v;
  };
  for (Eigen::Index j = 0; j < n; ++j) {
    const TrimParameterSpec& s = parameters[std::size_t(j)];
    // Central-difference steps: 0.5 deg for angles, 0.5 % of the frequency, and for the dimensionless shapes of the
    // Berman-Wang forms a step that keeps K inside (0, 1) and C positive.
    const double x0 = par.initial()[std::size_t(j)];
    const double h = s.name == "frequency_hz"     ? 0.005 * trimmed.frequency_hz
                     : s.name == "stroke_shape_k" ? 0.5 * std::min({0.01, x0, 1 - x0})
                     : s.name == "pitch_shape_c"  ? 0.01 * x0
                                                  : 0.5;
    std::vector<double> p = par.initial(), m = par.initial();
    p[std::size_t(j)] += h;
    m[std::size_t(j)] -= h;
    Eigen::Matrix<double, 6, 1> gp, gm;
    const Eigen::Matrix<double, 6, 1> wp = about_trim(par.apply(p), gp), wm = about_trim(par.apply(m), gm);
    out.gravity_si.col(j) = (gp - gm) / (2 * h);
    out.si.col(j) = (wp - wm) / (2 * h) + out.gravity_si.col(j);
    out.steps.push_back(h);
    ControlDerivative c;
    c.parameter = s.label();
    c.unit = TrimParameterization::unit(s.name);
    for (int i = 0; i < 6; ++i) c.nd(i) = out.si(i, j) / (i < 3 ? ref.force_scale() : ref.moment_scale());
    out.columns.push_back(c);
  }
  return out;
}

std::vector<TrimParameterSpec> actuated_parameters(const Case& c) {
  std::vector<TrimParameterSpec> out = c.trim.parameters;
  auto add = [&](const TrimParameterSpec& s) {
    for (const auto& o : out)
      if (o.label() == s.label()) return;
    out.push_back(s);
  };
  if (c.control.type == "pitch") add(unbounded_parameter(c.control.actuator));
  if (c.control.type == "state-feedback")
    for (const auto& a : c.control.actuators) add(a);
  return out;
}

}  // namespace flapstab
