// Cyclic hover trim: Newton shooting on the one-wingbeat map of the free body-plus-wings system.
#include "trim/cyclic.hpp"

#include <cmath>
#include <fmt/format.h>

#include "cfd/derivatives.hpp"
#include "core/errors.hpp"
#include "trim/newton.hpp"
#include "trim/ode.hpp"
#include "trim/parameters.hpp"

namespace flapstab {

namespace {

constexpr int n_ode = 13;  // the 12 body states and int_0^t theta dt
// Free initial states (indices into BodyStateVector) and the states the residuals compare.
constexpr int free_states[4] = {3, 5, 7, 10};              // u, w, q, theta
constexpr int residual_states[7] = {3, 5, 7, 10, 0, 2, 12};  // ..., x, z, int theta

OdeRhs free_rhs(const InstantaneousAero& aero) {
  return [&aero](double t, const Eigen::VectorXd& x, Eigen::VectorXd& dx) {
    const BodyStateVector d = free_flight_derivative(aero, t, x.head<12>());
    dx.resize(n_ode);
    dx.head<12>() = d;
    dx(12) = x(10);
  };
}

// The exact d(free_rhs)/dx for the quasi-steady model (cfd/quasi_steady's analytic wrench derivatives through
// core/eom's differentiated equations of motion); empty for other models (the ODE solver then differences).
struct FreeJacobian {
  const QuasiSteadyModel* qs = nullptr;
  SpanQuadrature span;
  FreeJacobian(const InstantaneousAero& aero, const AeroModel& model) : qs(dynamic_cast<const QuasiSteadyModel*>(&model)) {
    if (qs) span = span_quadrature(aero.insect(), qs->options().blade_elements);
  }
  OdeJacobian function(const InstantaneousAero& aero) const {
    if (!qs) return {};
    return [this, &aero](double t, const Eigen::VectorXd& x, Eigen::MatrixXd& J) {
      const BodyStateVector xb = x.head<12>();
      Eigen::Matrix<double, 6, 6> dw;
      qs->loads_jacobian(aero.configuration(), span, t, body_motion(xb), dw);
      J.setZero(n_ode, n_ode);
      J.topLeftCorner<12, 12>() = body_state_jacobian(aero.configuration(), t, xb, dw);
      J(12, 10) = 1;
    };
  }
};

OdeOptions ode_options(const ReferenceQuantities& ref, double period, double rtol) {
  OdeOptions o;
  o.rtol = rtol;
  o.scale.resize(n_ode);
  o.scale << ref.c, ref.c, ref.c, ref.U, ref.U, ref.U, ref.U / ref.c, ref.U / ref.c, ref.U / ref.c, 1, 1, 1,
      period;
  return o;
}

class Shooting {
 public:
  // free_attitude: the mean-pitch equation is left out (six residuals), the orbit's mean attitude is its own.
  Shooting(const Case& c, const AeroModel& model, const TrimParameterization& par, const ReferenceQuantities& ref,
           double rtol, bool free_attitude)
      : case_(c), model_(model), par_(par), ref_(ref), rtol_(rtol), nres_(free_attitude ? 6 : 7) {
    // z = [u0 / U, w0 / U, q0 c / U, theta0, parameters / (upper - lower)]
    zs_ = {1 / ref.U, 1 / ref.U, ref.c / ref.U, 1.0};
    for (const auto& s : par.specs()) zs_.push_back(1 / (s.upper - s.lower));
    // residuals: velocities / U, rate c / U, angle, positions / c, mean angle
    rs_ = {1 / ref.U, 1 / ref.U, ref.c / ref.U, 1.0, 1 / ref.c, 1 / ref.c, 0.0};
  }
  Eigen::Index unknowns() const { return Eigen::Index(zs_.size()); }
  int integrations() const { return integrations_; }

  std::vector<double> parameters(const Eigen::VectorXd& z) const {
    std::vector<double> p;
    for (Eigen::Index j = 4; j < z.size(); ++j) p.push_back(z(j) / zs_[std::size_t(j)]);
    return p;
  }
  Eigen::VectorXd to_z(const BodyStateVector& x0, const std::vector<double>& p) const {
    Eigen::VectorXd z(unknowns());
    for (int j = 0; j < 4; ++j) z(j) = x0(free_states[j]) * zs_[std::size_t(j)];
    for (std::size_t j = 0; j < p.size(); ++j) z(Eigen::Index(4 + j)) = p[j] * zs_[4 + j];
    return z;
  }
  BodyStateVector initial_state(const Eigen::VectorXd& z) const {
    BodyStateVector x = BodyStateVector::Zero();
    for (int j = 0; j < 4; ++j) x(free_states[j]) = z(j) / zs_[std::size_t(j)];
    return x;
  }

  // Scaled residual; with jacobian != nullptr also d r / d z.
  Eigen::VectorXd residual(const Eigen::VectorXd& z, Eigen::MatrixXd* jacobian) {
    const Kinematics kin = par_.apply(parameters(z));
    const InstantaneousAero aero(model_, case_.insect, kin);
    const double T = kin.period();
    rs_[6] = 1 / T;
    Eigen::VectorXd x0 = Eigen::VectorXd::Zero(n_ode);
    x0.head<12>() = initial_state(z);
    std::vector<int> sens;
    if (jacobian) sens.assign(std::begin(free_states), std::end(free_states));
    const FreeJacobian fj(aero, model_);
    OdeOptions opts = ode_options(ref_, T, rtol_);
    opts.jacobian = fj.function(aero);
    const OdeSolution s = integrate_ode(free_rhs(aero), x0, 0, T, sens, {}, opts);
    ++integrations_;
    Eigen::VectorXd r(nres_);
    for (int i = 0; i < nres_; ++i) {
      const int k = residual_states[i];
      r(i) = rs_[std::size_t(i)] * (s.x(k) - (i < 4 ? x0(k) : 0.0));
    }
    if (jacobian) {
      Eigen::MatrixXd& J = *jacobian;
      J.resize(nres_, unknowns());
      for (int i = 0; i < nres_; ++i)
        for (int j = 0; j < 4; ++j)
          J(i, j) = rs_[std::size_t(i)] * (s.sensitivity(residual_states[i], j) - (i == j ? 1.0 : 0.0)) /
                    zs_[std::size_t(j)];
      // Parameter columns: central differences of the period map, step 1e-5 of the bounds' range.
      for (Eigen::Index j = 4; j < unknowns(); ++j) {
        const double h = 1e-5;
        Eigen::VectorXd zp = z, zm = z;
        zp(j) += h;
        zm(j) -= h;
        J.col(j) = (residual(zp, nullptr) - residual(zm, nullptr)) / (2 * h);
      }
      rs_[6] = 1 / T;
    }
    return r;
  }

 private:
  const Case& case_;
  const AeroModel& model_;
  const TrimParameterization& par_;
  ReferenceQuantities ref_;
  double rtol_;
  int nres_;
  std::vector<double> zs_, rs_;
  int integrations_ = 0;
};

}  // namespace

std::vector<BodyStateVector> periodic_orbit(const InstantaneousAero& aero, const BodyStateVector& x0, int N,
                                            double rtol) {
  const double T = aero.kinematics().period();
  const ReferenceQuantities ref = reference_quantities(aero.insect(), aero.kinematics(), FluidProperties{});
  std::vector<double> times;
  for (int k = 0; k < N; ++k) times.push_back(T * k / N);
  Eigen::VectorXd y0 = Eigen::VectorXd::Zero(n_ode);
  y0.head<12>() = x0;
  const OdeSolution s = integrate_ode(free_rhs(aero), y0, 0, T, {}, times, ode_options(ref, T, rtol));
  std::vector<BodyStateVector> out;
  for (const auto& v : s.samples) out.push_back(v.head<12>());
  return out;
}

void check_cyclic_trim_case(const Case& c, const AeroModel& model) {
  const TrimParameterization par(c.kinematics, c.trim.parameters, c.path);
  if (par.one_sided() || !c.kinematics.symmetric())
    throw InputError(c.path, "trim.parameter",
                     "the cyclic trim solves the longitudinal subsystem of a symmetric insect; this case has "
                     "one-sided parameters or asymmetric kinematics",
                     "symmetric kinematics and parameters acting on both wings");
  if (!model.is_instantaneous())
    throw InputError(c.path, "aero.model",
                     "the " + model.name() + " model has no instantaneous loads, which the cyclic trim needs",
                     "model = \"quasi-steady\"");
}

CyclicTrimResult cyclic_trim(const Case& c, const AeroModel& model, const TrimResult& averaged,
                             const CyclicTrimOptions& o) {
  check_cyclic_trim_case(c, model);
  if (averaged.parameters.size() != c.trim.parameters.size())
    throw InputError(c.path, "trim.parameter", "the averaged trim does not match the case's [trim] parameters");
  // Imposed attitude: every [trim] parameter, from the case's kinematics. Free attitude: body_angle_deg stays at the
  // averaged trim's value (the orbit's mean pitch takes its place), the others act on the averaged trim's kinematics.
  const bool free_attitude = c.trim.cyclic_attitude == "free";
  std::vector<TrimParameterSpec> specs;
  std::vector<double> p0;
  for (std::size_t i = 0; i < c.trim.parameters.size(); ++i) {
    if (free_attitude && c.trim.parameters[i].name == "body_angle_deg") continue;
    specs.push_back(c.trim.parameters[i]);
    p0.push_back(averaged.parameters[i].value);
  }
  if (free_attitude && specs.size() == c.trim.parameters.size())
    throw InputError(c.path, "trim.cyclic_attitude", "\"free\" needs body_angle_deg among the [trim] parameters",
                     "a [[trim.parameter]] with name = \"body_angle_deg\"");
  const TrimParameterization par(free_attitude ? averaged.kinematics : c.kinematics, specs, c.path);
  const ReferenceQuantities ref = reference_quantities(c.insect, averaged.kinematics, c.fluid);
  Shooting shoot(c, model, par, ref, o.rtol, free_attitude);
  Eigen::VectorXd z = shoot.to_z(BodyStateVector::Zero(), p0);

  CyclicTrimResult res;
  res.free_attitude = free_attitude;
  res.residual_names = {"u", "w", "q", "theta", "x_drift", "z_drift"};
  if (!free_attitude) res.residual_names.push_back("mean_theta");
  const NewtonOutcome n = newton_solve(
      [&shoot](const Eigen::VectorXd& zz, Eigen::MatrixXd* J) { return shoot.residual(zz, J); }, z, o.tolerance,
      o.max_iterations);
  z = n.z;
  res.converged = n.converged;
  res.iterations = n.iterations;
  res.message = n.message;
  res.residuals = n.r;
  res.residual = n.r.cwiseAbs().maxCoeff();

  const std::vector<double> p = shoot.parameters(z);
  res.kinematics = par.apply(p);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto& s = par.specs()[i];
    res.parameters.push_back({s.name, s.label(), TrimParameterization::unit(s.name), p[i], p0[i], s.lower, s.upper});
    if (p[i] < s.lower || p[i] > s.upper)
      res.message += fmt::format("{}{} = {:.6g} lies outside its bounds [{:g}, {:g}]", res.message.empty() ? "" : "; ",
                                 s.label(), p[i], s.lower, s.upper);
  }
  res.initial_state = shoot.initial_state(z);
  res.period = res.kinematics.period();

  // The converged orbit: monodromy (all eight linear states), oscillation, symmetry check.
  const InstantaneousAero aero(model, c.insect, res.kinematics);
  const int N = o.amplitude_samples;
  std::vector<double> times;
  for (int k = 0; k < N; ++k) times.push_back(res.period * k / N);
  Eigen::VectorXd y0 = Eigen::VectorXd::Zero(n_ode);
  y0.head<12>() = res.initial_state;
  const FreeJacobian fj(aero, model);
  OdeOptions opts = ode_options(ref, res.period, o.rtol);
  opts.jacobian = fj.function(aero);
  const OdeSolution s = integrate_ode(free_rhs(aero), y0, 0, res.period, {3, 4, 5, 6, 7, 8, 9, 10}, times, opts);
  res.integrations = shoot.integrations() + 1;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) res.monodromy(i, j) = s.sensitivity(3 + i, j);
  res.mean_theta = s.x(12) / res.period;
  res.mean_body_angle = res.kinematics.body_angle + res.mean_theta;
  Eigen::Vector4d lo = Eigen::Vector4d::Constant(1e300), hi = -lo;
  for (const auto& x : s.samples) {
    for (int j = 0; j < 4; ++j) {
      lo(j) = std::min(lo(j), x(free_states[j]));
      hi(j) = std::max(hi(j), x(free_states[j]));
      res.mean_si(j) += x(free_states[j]) / N;
    }
    const double sym = std::max({std::abs(x(4)) / ref.U, std::abs(x(6)) * ref.c / ref.U, std::abs(x(8)) * ref.c / ref.U,
                                 std::abs(x(9)), std::abs(x(11)), std::abs(x(1)) / ref.c});
    res.symmetry_residual = std::max(res.symmetry_residual, sym);
  }
  res.amplitude_si = (hi - lo) / 2;
  const Eigen::Vector4d nd(1 / ref.U, 1 / ref.U, ref.c / ref.U, 1.0);
  res.amplitude_nd = res.amplitude_si.cwiseProduct(nd);
  return res;
}

}  // namespace flapstab
