// Closed-loop delay systems from plants and controllers; neutral axis.
#include "flight/control_analysis.hpp"

#include <algorithm>
#include <fmt/format.h>
#include "core/errors.hpp"
#include "stability/floquet.hpp"

namespace flapstab {

namespace {

Eigen::VectorXd state_scale(const std::vector<std::string>& states, const ReferenceQuantities& ref) {
  return nondimensional_state_scale(states, ref);  // x_nd = D x_si
}

int index_in(const std::vector<std::string>& v, const std::string& s) {
  const auto it = std::find(v.begin(), v.end(), s);
  return it == v.end() ? -1 : int(it - v.begin());
}

struct LoopTerms {
  Eigen::MatrixXd A;  // plant A augmented with the filter states
  std::vector<std::pair<double, Eigen::MatrixXd>> delayed;  // (tau, B) grouped by latency
};

// The loop's matrices given the input columns b(actuator) of an n-state plant.
LoopTerms loop_terms(const Eigen::MatrixXd& A, const std::function<Eigen::VectorXd(int)>& b,
                     const std::vector<std::string>& states, const std::vector<std::string>& inputs,
                     const ControllerSpec& c, const std::string& file, const std::string& key) {
  const Eigen::Index n = A.rows();
  int filters = 0;
  for (const auto& t : c.terms) filters += t.filter_time_s > 0;
  const Eigen::Index m = n + filters;
  LoopTerms L;
  L.A = Eigen::MatrixXd::Zero(m, m);
  L.A.topLeftCorner(n, n) = A;
  int f = 0;
  auto add_delayed = [&](double tau, const Eigen::MatrixXd& contrib) {
    for (auto& [t, B] : L.delayed)
      if (t == tau) {
        B += contrib;
        return;
      }
    L.delayed.emplace_back(tau, contrib);
  };
  for (std::size_t i = 0; i < c.terms.size(); ++i) {
    const FeedbackTerm& t = c.terms[i];
    const int j = index_in(states, t.state);
    if (j < 0)
      throw InputError(file, fmt::format("{}[{}].state", key, i),
                       "the state \"" + t.state + "\" is not in the " + fmt::format("{}", fmt::join(states, ", ")) +
                           " system analysed",
                       "a state of that system");
    const int a = index_in(inputs, t.actuator);
    if (a < 0)
      throw InputError(file, fmt::format("{}[{}].actuator", key, i),
                       "no control derivative for \"" + t.actuator + "\"", "an actuator with control derivatives");
    const Eigen::VectorXd bcol = b(a);
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(m, m);
    if (t.filter_time_s > 0) {
      // s' = (x_j(t - tau) - s) / T_f, command -gain s (no further delay).
      const Eigen::Index s = n + f++;
      L.A(s, s) -= 1 / t.filter_time_s;
      L.A.block(0, s, n, 1) -= t.gain * bcol;
      D(s, j) = 1 / t.filter_time_s;
    } else {
      D.block(0, j, n, 1) = -t.gain * bcol;
    }
    if (t.latency_s == 0) L.A += D;
    else add_delayed(t.latency_s, D);
  }
  return L;
}

}  // namespace

LinearPlant averaged_plant(const StateSpace& s, const ReferenceQuantities& ref) {
  const Eigen::VectorXd D = state_scale(s.state_order, ref);
  const double ts = ref.time_scale();
  LinearPlant p;
  p.name = s.name;
  p.states = s.state_order;
  p.inputs = s.input_order;
  p.A = D.cwiseInverse().asDiagonal() * s.A * D.asDiagonal() / ts;
  p.B = D.cwiseInverse().asDiagonal() * s.B / ts;
  return p;
}

DelaySystem closed_loop(const LinearPlant& p, const ControllerSpec& c, const std::string& file,
                        const std::string& key) {
  const LoopTerms L = loop_terms(p.A, [&](int a) -> Eigen::VectorXd { return p.B.col(a); }, p.states, p.inputs, c,
                                 file, key);
  DelaySystem d;
  d.A = L.A;
  for (const auto& [tau, B] : L.delayed) d.delayed.push_back({B, tau});
  return d;
}

PeriodicPlant periodic_plant(const FlightDynamics& dyn, const PhaseDerivatives& phase,
                             const std::vector<std::string>& states) {
  const auto& names = linear_state_names();
  std::vector<int> idx;
  for (const auto& s : states) {
    const int i = index_in(names, s);
    if (i < 0) throw SolveError("periodic_plant: unknown state " + s);
    idx.push_back(i);
  }
  PeriodicPlant p;
  p.period = phase.period;
  p.states = states;
  for (const auto& a : dyn.actuators()) p.inputs.push_back(a.label());
  p.A = phase.system_samples(idx);
  const Eigen::Index n = Eigen::Index(idx.size()), na = Eigen::Index(p.inputs.size());
  for (const auto& s : phase.samples) {
    Eigen::MatrixXd B(n, na);
    for (Eigen::Index a = 0; a < na; ++a) {
      const double h = dyn.actuators()[std::size_t(a)].name == "frequency_hz" ? 0.005 * dyn.trimmed().frequency_hz : 0.5;
      std::vector<double> cp(std::size_t(na), 0.0), cm(std::size_t(na), 0.0);
      cp[std::size_t(a)] = h;
      cm[std::size_t(a)] = -h;
      const BodyStateVector d = (dyn.derivative(s.time, s.state, cp).dx - dyn.derivative(s.time, s.state, cm).dx) / (2 * h);
      for (Eigen::Index i = 0; i < n; ++i) B(i, a) = d(linear_state_index[idx[std::size_t(i)]]);
    }
    p.B.push_back(B);
  }
  return p;
}

PeriodicDelaySystem closed_loop(const PeriodicPlant& p, const ControllerSpec& c, const std::string& file,
                                const std::string& key) {
  auto As = std::make_shared<PeriodicMatrixSpline>(p.period, p.A);
  auto Bs = std::make_shared<PeriodicMatrixSpline>(p.period, p.B);
  // The loop's structure (which entries, which delays) is the same at every t; its values follow A(t), B(t).
  auto structure = [=](double t) {
    const Eigen::MatrixXd A = (*As)(t), B = (*Bs)(t);
    return loop_terms(A, [&](int a) -> Eigen::VectorXd { return B.col(a); }, p.states, p.inputs, c, file, key);
  };
  const LoopTerms L0 = structure(0);  // validates names
  PeriodicDelaySystem d;
  d.period = p.period;
  d.n = L0.A.rows();
  d.A = [structure](double t) { return structure(t).A; };
  for (std::size_t j = 0; j < L0.delayed.size(); ++j) {
    d.tau.push_back(L0.delayed[j].first);
    d.B.push_back([structure, j](double t) { return structure(t).delayed[j].second; });
  }
  return d;
}

ControllerSpec controller_at(const PitchControllerSettings& base, MapGain which, double gain, double latency,
                             double trim) {
  PitchControllerSettings s = base;
  (which == MapGain::pitch ? s.pitch_gain : s.rate_gain_s) = gain;
  s.pitch_latency_s = s.rate_latency_s = latency;
  return pitch_controller(s, trim);
}

NeutralAxis neutral_axis(const DerivativeTable& t) {
  const auto& r = t.reference;
  NeutralAxis a;
  a.Xu = t.at("Xu") * r.force_scale() / r.U;
  a.Zu = t.at("Zu") * r.force_scale() / r.U;
  a.Mu = t.at("Mu") * r.moment_scale() / r.U;
  if (a.Xu == 0) throw SolveError("neutral axis: X_u = 0, the axis is not defined");
  a.z_at_com = a.Mu / a.Xu;
  a.slope = a.Zu / a.Xu;
  a.com_below_axis_m = -a.z_at_com;
  return a;
}

}  // namespace flapstab
