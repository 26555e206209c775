// The translation-only model: prescribed attitude, free translation; its cyclic trim and monodromy.
#include "trim/translation.hpp"

#include <cmath>
#include <fmt/format.h>

#include "cfd/derivatives.hpp"
#include "core/errors.hpp"
#include "core/rotation.hpp"
#include "trim/newton.hpp"
#include "trim/ode.hpp"
#include "trim/parameters.hpp"

namespace flapstab {

PrescribedAttitude prescribed_attitude(const BodyMotionSettings& b, double n, double t) {
  const double tau = t * n;
  const SeriesValue R = b.roll.eval(tau), P = b.pitch.eval(tau), Y = b.yaw.eval(tau);
  const double ph = R.f, th = P.f, dph = R.df * n, dth = P.df * n, dps = Y.df * n;
  const double ddph = R.ddf * n * n, ddth = P.ddf * n * n, ddps = Y.ddf * n * n;
  const double sf = std::sin(ph), cf = std::cos(ph), st = std::sin(th), ct = std::cos(th);
  PrescribedAttitude a;
  a.phi = ph;
  a.theta = th;
  a.psi = Y.f;
  // Body rates of 3-2-1 Euler angles and their time derivatives.
  a.rates = Vec3(dph - dps * st, dth * cf + dps * sf * ct, -dth * sf + dps * cf * ct);
  a.rates_dot = Vec3(ddph - ddps * st - dps * dth * ct,
                     ddth * cf - dth * dph * sf + ddps * sf * ct + dps * dph * cf * ct - dps * dth * sf * st,
                     -ddth * sf - dth * dph * cf + ddps * cf * ct - dps * dph * sf * ct - dps * dth * cf * st);
  return a;
}

BodyStateVector translation_body_state(const BodyMotionSettings& b, double n, double t, const TranslationState& y) {
  const PrescribedAttitude a = prescribed_attitude(b, n, t);
  BodyStateVector x;
  x << y, a.rates, a.phi, a.theta, a.psi;
  return x;
}

TranslationState translation_derivative(const InstantaneousAero& aero, const BodyMotionSettings& b, double t,
                                        const TranslationState& y, std::optional<double> g) {
  const double n = aero.kinematics().frequency_hz;
  const PrescribedAttitude a = prescribed_attitude(b, n, t);
  BodyStateVector x;
  x << y, a.rates, a.phi, a.theta, a.psi;
  const Wrench w = aero(t, body_motion(x));
  const EomTerms e = eom_terms(aero.configuration().mass_state(t), x, w, g.value_or(aero.insect().gravity));
  // Force rows of the mass matrix: [m I, -[c]x] [v'; w'] = rhs_F, with w' prescribed.
  const double m = e.mass_matrix(0, 0);
  TranslationState d;
  d.head<3>() = euler321(a.phi, a.theta, a.psi) * y.tail<3>();
  d.tail<3>() = (e.rhs.head<3>() - e.mass_matrix.topRightCorner<3, 3>() * a.rates_dot) / m;
  return d;
}

namespace {

OdeRhs translation_rhs(const InstantaneousAero& aero, const BodyMotionSettings& b) {
  return [&aero, &b](double t, const Eigen::VectorXd& y, Eigen::VectorXd& dy) {
    dy = translation_derivative(aero, b, t, y.head<6>());
  };
}

OdeOptions translation_ode_options(const ReferenceQuantities& ref, double rtol) {
  OdeOptions o;
  o.rtol = rtol;
  o.scale.resize(6);
  o.scale << ref.c, ref.c, ref.c, ref.U, ref.U, ref.U;
  return o;
}

std::vector<TrimParameterSpec> translation_parameters(const Case& c) {
  std::vector<TrimParameterSpec> specs;
  for (const std::string& name : c.body_motion.trim_parameters)
    for (const auto& s : c.trim.parameters)
      if (s.name == name) specs.push_back(s);
  return specs;
}

}  // namespace

void check_translation_case(const Case& c, const AeroModel& model) {
  if (!c.body_motion.present)
    throw InputError(c.path, "body_motion", "missing section", "[body_motion] model = \"translation-only\"");
  if (!model.is_instantaneous())
    throw InputError(c.path, "aero.model",
                     "the " + model.name() + " model has no instantaneous loads, which the translation-only model needs",
                     "model = \"quasi-steady\"");
  const auto specs = translation_parameters(c);
  if (specs.size() != c.body_motion.trim_parameters.size())
    throw InputError(c.path, "body_motion.trim_parameters", "names a parameter that is not in [[trim.parameter]]",
                     "names of the case's [[trim.parameter]] entries (their bounds apply)");
}

TranslationTrimResult translation_cyclic_trim(const Case& c, const AeroModel& model, const Kinematics& start,
                                              const CyclicTrimOptions& o) {
  check_translation_case(c, model);
  const TrimParameterization par(start, translation_parameters(c), c.path);
  const ReferenceQuantities ref = reference_quantities(c.insect, start, c.fluid);
  const BodyMotionSettings& b = c.body_motion;
  // z = [u0 v0 w0] / U and the parameters / (upper - lower); r = [velocity change] / U, [drift] / c.
  std::vector<double> zs(3, 1 / ref.U);
  for (const auto& s : par.specs()) zs.push_back(1 / (s.upper - s.lower));
  auto parameters = [&](const Eigen::VectorXd& z) {
    std::vector<double> p;
    for (Eigen::Index j = 3; j < z.size(); ++j) p.push_back(z(j) / zs[std::size_t(j)]);
    return p;
  };
  int integrations = 0;
  const std::vector<int> velocity{3, 4, 5};
  ResidualFunction residual = [&](const Eigen::VectorXd& z, Eigen::MatrixXd* J) -> Eigen::VectorXd {
    const Kinematics kin = par.apply(parameters(z));
    const InstantaneousAero aero(model, c.insect, kin);
    Eigen::VectorXd y0 = Eigen::VectorXd::Zero(6);
    for (int i = 0; i < 3; ++i) y0(3 + i) = z(i) / zs[std::size_t(i)];
    const OdeSolution s =
        integrate_ode(translation_rhs(aero, b), y0, 0, kin.period(), J ? velocity : std::vector<int>{}, {},
                      translation_ode_options(ref, o.rtol));
    ++integrations;
    Eigen::VectorXd r(6);
    for (int i = 0; i < 3; ++i) {
      r(i) = (s.x(3 + i) - y0(3 + i)) / ref.U;
      r(3 + i) = s.x(i) / ref.c;
    }
    if (J) {
      J->resize(6, z.size());
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 3; ++j) {
          const int k = i < 3 ? 3 + i : i - 3;
          (*J)(i, j) = (s.sensitivity(k, j) - (k == 3 + j ? 1.0 : 0.0)) / (i < 3 ? ref.U : ref.c) / zs[std::size_t(j)];
        }
      // Parameter columns: central differences of the period map, step 1e-5 of the bounds' range.
      for (Eigen::Index j = 3; j < z.size(); ++j) {
        const double h = 1e-5;
        Eigen::VectorXd zp = z, zm = z;
        zp(j) += h;
        zm(j) -= h;
        J->col(j) = (residual(zp, nullptr) - residual(zm, nullptr)) / (2 * h);
      }
    }
    return r;
  };
  Eigen::VectorXd z = Eigen::VectorXd::Zero(Eigen::Index(zs.size()));
  for (std::size_t j = 0; j < par.size(); ++j) z(Eigen::Index(3 + j)) = par.initial()[j] * zs[3 + j];
  const NewtonOutcome nr = newton_solve(residual, z, o.tolerance, o.max_iterations);

  TranslationTrimResult res;
  res.residual_names = {"u", "v", "w", "x_drift", "y_drift", "z_drift"};
  res.converged = nr.converged;
  res.iterations = nr.iterations;
  res.message = nr.message;
  res.residuals = nr.r;
  res.residual = nr.r.cwiseAbs().maxCoeff();
  const std::vector<double> p = parameters(nr.z);
  res.kinematics = par.apply(p);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto& s = par.specs()[i];
    res.parameters.push_back(
        {s.name, s.label(), TrimParameterization::unit(s.name), p[i], par.initial()[i], s.lower, s.upper});
    if (p[i] < s.lower || p[i] > s.upper)
      res.message += fmt::format("{}{} = {:.6g} lies outside its bounds [{:g}, {:g}]", res.message.empty() ? "" : "; ",
                                 s.label(), p[i], s.lower, s.upper);
  }
  for (int i = 0; i < 3; ++i) res.initial_velocity(i) = nr.z(i) / zs[std::size_t(i)];
  res.period = res.kinematics.period();

  // The converged orbit: monodromy of [u v w] and the cycle-mean velocity.
  const InstantaneousAero aero(model, c.insect, res.kinematics);
  const int N = o.amplitude_samples;
  std::vector<double> times;
  for (int k = 0; k < N; ++k) times.push_back(res.period * k / N);
  Eigen::VectorXd y0 = Eigen::VectorXd::Zero(6);
  y0.tail<3>() = res.initial_velocity;
  const OdeSolution s = integrate_ode(translation_rhs(aero, b), y0, 0, res.period, velocity, times,
                                      translation_ode_options(ref, o.rtol));
  res.integrations = integrations + 1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) res.monodromy(i, j) = s.sensitivity(3 + i, j);
  for (const auto& y : s.samples) res.mean_velocity += y.tail<3>() / N;
  return res;
}

}  // namespace flapstab
