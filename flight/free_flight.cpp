// Free flight: Dormand-Prince 5(4) over the body state, filter states and wingbeat phase, with delayed feedback.
#include "flight/free_flight.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include "core/errors.hpp"
#include "flight/delay_line.hpp"
#include "stability/floquet.hpp"

namespace flapstab {

ReferenceOrbit reference_orbit(const std::vector<BodyStateVector>& samples, double period) {
  std::vector<Eigen::MatrixXd> m;
  ReferenceOrbit r;
  for (const auto& s : samples) {
    m.push_back(s);
    r.mean += s;
  }
  r.mean /= double(samples.size());
  auto spline = std::make_shared<PeriodicMatrixSpline>(period, std::move(m));
  r.state = [spline](double t) -> BodyStateVector { return (*spline)(t); };
  return r;
}

namespace {

// Dormand-Prince 5(4) tableau.
constexpr double c2 = 1. / 5, c3 = 3. / 10, c4 = 4. / 5, c5 = 8. / 9;
constexpr double a21 = 1. / 5;
constexpr double a31 = 3. / 40, a32 = 9. / 40;
constexpr double a41 = 44. / 45, a42 = -56. / 15, a43 = 32. / 9;
constexpr double a51 = 19372. / 6561, a52 = -25360. / 2187, a53 = 64448. / 6561, a54 = -212. / 729;
constexpr double a61 = 9017. / 3168, a62 = -355. / 33, a63 = 46732. / 5247, a64 = 49. / 176, a65 = -5103. / 18656;
constexpr double b1 = 35. / 384, b3 = 500. / 1113, b4 = 125. / 192, b5 = -2187. / 6784, b6 = 11. / 84;
constexpr double e1 = 71. / 57600, e3 = -71. / 16695, e4 = 71. / 1920, e5 = -17253. / 339200, e6 = 22. / 525,
                 e7 = -1. / 40;

// The augmented system: y = [12 body states | one filter state per filtered term | wingbeat phase (cycles)].
class FlightSystem {
 public:
  FlightSystem(const FlightDynamics& dyn, const ControllerSpec& ctrl, const ReferenceOrbit& ref)
      : dyn_(dyn), ctrl_(ctrl), ref_(ref), history_(ref.state), bound_(dyn, ctrl) {
    held_.assign(dyn.actuators().size(), 0.0);
    freq_ = dyn.actuator_index("frequency_hz");
  }
  Eigen::Index size() const { return 12 + bound_.filters + 1; }
  DelayLine& history() { return history_; }

  Eigen::VectorXd initial(const BodyStateVector& x0) const {
    Eigen::VectorXd y = Eigen::VectorXd::Zero(size());
    y.head<12>() = x0;
    for (const auto& t : bound_.terms)
      if (t.filter >= 0) y(12 + t.filter) = sensed_raw(t, 0, x0);
    return y;
  }

  // The command at time t from the augmented state (continuous) or the held value (wingbeat).
  std::vector<double> command(double t, const Eigen::VectorXd& y) const {
    if (ctrl_.update == ControlUpdate::wingbeat) return held_;
    return law(t, y);
  }
  void sample_and_hold(double t, const Eigen::VectorXd& y) { held_ = law(t, y); }

  Eigen::VectorXd rhs(double t, const Eigen::VectorXd& y, FlightDerivative* full = nullptr,
                      std::vector<double>* cmd_out = nullptr) const {
    const BodyStateVector x = y.head<12>();
    const std::vector<double> cmd = command(t, y);
    const double f = dyn_.trimmed().frequency_hz + (freq_ ? cmd[std::size_t(*freq_)] : 0.0);
    const double t_kin = y(size() - 1) / f;
    const FlightDerivative d = dyn_.derivative(t_kin, x, cmd);
    Eigen::VectorXd dy(size());
    dy.head<12>() = d.dx;
    for (const auto& term : bound_.terms)
      if (term.filter >= 0)
        dy(12 + term.filter) = (sensed_raw(term, t, x) - y(12 + term.filter)) / term.spec.filter_time_s;
    dy(size() - 1) = f;
    if (full) *full = d;
    if (cmd_out) *cmd_out = cmd;
    return dy;
  }

 private:
  using Term = BoundController::Term;
  // Sensed deviation of a term before filtering: the delayed (or, without latency, current) state minus the
  // hover reference.
  double sensed_raw(const Term& term, double t, const BodyStateVector& x_now) const {
    const double td = t - term.spec.latency_s;
    const double v = term.spec.latency_s > 0 ? history_.at(td)(term.state) : x_now(term.state);
    return v - (ctrl_.sense_orbit_deviation ? ref_.state(td)(term.state) : ref_.mean(term.state));
  }
  std::vector<double> law(double t, const Eigen::VectorXd& y) const {
    const BodyStateVector x = y.head<12>();
    return bound_.law([&](const Term& term) { return term.filter >= 0 ? y(12 + term.filter) : sensed_raw(term, t, x); });
  }
  const FlightDynamics& dyn_;
  const ControllerSpec& ctrl_;
  const ReferenceOrbit& ref_;
  DelayLine history_;
  BoundController bound_;
  std::vector<double> held_;
  std::optional<int> freq_;
};

}  // namespace

BoundController::BoundController(const FlightDynamics& dyn, const ControllerSpec& c) {
  for (const auto& t : c.terms) {
    Term term;
    term.state = *body_state_index(t.state);
    const auto a = dyn.actuator_index(t.actuator);
    if (!a) throw SolveError("free flight: actuator \"" + t.actuator + "\" is not among the dynamics' actuators");
    term.actuator = *a;
    term.spec = t;
    term.filter = t.filter_time_s > 0 ? filters++ : -1;
    terms.push_back(term);
  }
  lower.assign(dyn.actuators().size(), -1e300);
  upper.assign(dyn.actuators().size(), 1e300);
  for (const auto& a : c.actuators) {
    const auto i = dyn.actuator_index(a.label());
    if (!i) throw SolveError("free flight: actuator \"" + a.label() + "\" is not among the dynamics' actuators");
    lower[std::size_t(*i)] = a.lower - dyn.actuator_trim()[std::size_t(*i)];
    upper[std::size_t(*i)] = a.upper - dyn.actuator_trim()[std::size_t(*i)];
  }
}

FlightResult simulate_flight(const FlightDynamics& dyn, const ControllerSpec& ctrl, const BodyStateVector& x0,
                             const ReferenceOrbit& reference, const ReferenceQuantities& ref,
                             const FlightOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!(o.wingbeats > 0) || o.samples_per_wingbeat < 1 || !(o.rtol > 0))
    throw InputError("", "flight", "wingbeats, samples_per_wingbeat and rtol must be positive");
  FlightSystem sys(dyn, ctrl, reference);
  const long evals0 = dyn.evaluations();
  const double T = dyn.trimmed().period();
  const Eigen::Index n = sys.size();
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(n);
  scale.head<12>() << ref.c, ref.c, ref.c, ref.U, ref.U, ref.U, ref.U / ref.c, ref.U / ref.c, ref.U / ref.c, 1, 1, 1;
  const double tau_min = ctrl.min_positive_latency();
  const double h_max = tau_min > 0 ? std::min(T / 8, tau_min) : T / 8;

  FlightResult res;
  Eigen::VectorXd y = sys.initial(dyn.held(x0));
  double t = 0, h = T / 200;
  FlightDerivative d0;
  std::vector<double> cmd0;
  if (ctrl.update == ControlUpdate::wingbeat) sys.sample_and_hold(0, y);
  Eigen::VectorXd k1 = sys.rhs(t, y, &d0, &cmd0);
  sys.history().push(t, y.head<12>(), k1.head<12>());
  auto record = [&](double ts, const Eigen::VectorXd& ys) {
    FlightSample s;
    FlightDerivative d;
    sys.rhs(ts, ys, &d, &s.command);
    s.t = ts;
    s.x = ys.head<12>();
    s.aero = d.aero;
    s.power = d.power;
    res.samples.push_back(std::move(s));
  };
  record(0, y);
  const int total_beats = int(std::ceil(o.wingbeats - 1e-12));
  const long total_samples = std::lround(o.wingbeats * o.samples_per_wingbeat);
  long next_sample = 1;
  const double dt_sample = T / o.samples_per_wingbeat;
  for (int beat = 0; beat < total_beats && res.completed; ++beat) {
    const double t_end = std::min((beat + 1) * T, o.wingbeats * T);
    if (beat > 0 && ctrl.update == ControlUpdate::wingbeat) {
      sys.sample_and_hold(t, y);
      k1 = sys.rhs(t, y);  // the command jumps: restart the FSAL stage
    }
    // An output time on this wingbeat's start is recorded after the update, with the command that holds from it.
    while (next_sample <= total_samples && next_sample * dt_sample <= t * (1 + 1e-13)) {
      record(t, y);
      ++next_sample;
    }
    while (t < t_end * (1 - 1e-14) && res.completed) {
      bool last = false;
      if (t + h >= t_end) {
        h = t_end - t;
        last = true;
      }
      h = std::min(h, h_max);
      if (t + h >= t_end * (1 - 1e-14)) last = true;
      const Eigen::VectorXd k2 = sys.rhs(t + c2 * h, y + h * a21 * k1);
      const Eigen::VectorXd k3 = sys.rhs(t + c3 * h, y + h * (a31 * k1 + a32 * k2));
      const Eigen::VectorXd k4 = sys.rhs(t + c4 * h, y + h * (a41 * k1 + a42 * k2 + a43 * k3));
      const Eigen::VectorXd k5 = sys.rhs(t + c5 * h, y + h * (a51 * k1 + a52 * k2 + a53 * k3 + a54 * k4));
      const Eigen::VectorXd k6 =
          sys.rhs(t + h, y + h * (a61 * k1 + a62 * k2 + a63 * k3 + a64 * k4 + a65 * k5));
      const Eigen::VectorXd y_new = y + h * (b1 * k1 + b3 * k3 + b4 * k4 + b5 * k5 + b6 * k6);
      const double t_new = last ? t_end : t + h;
      const Eigen::VectorXd k7 = sys.rhs(t_new, y_new);
      const Eigen::VectorXd err = h * (e1 * k1 + e3 * k3 + e4 * k4 + e5 * k5 + e6 * k6 + e7 * k7);
      double e = 0;
      for (Eigen::Index i = 0; i < n; ++i) {
        const double w = o.rtol * (std::max(std::abs(y(i)), std::abs(y_new(i))) + scale(i));
        e += (err(i) / w) * (err(i) / w);
      }
      e = std::sqrt(e / double(n));
      if (!std::isfinite(e) || !y_new.allFinite()) {
        if (h < 1e-12 * T)
          throw SolveError(fmt::format("free flight: the state became non-finite at t = {:.6g} s", t));
        h *= 0.25;
        ++res.rejected;
        continue;
      }
      if (e > 1) {
        h *= std::clamp(0.9 * std::pow(e, -0.2), 0.2, 1.0);
        ++res.rejected;
        continue;
      }
      // Accepted: output samples inside (t, t_new] by Hermite interpolation of the step.
      const bool final_step = last && beat == total_beats - 1;
      while (next_sample <= total_samples && (next_sample * dt_sample < t_end * (1 - 1e-13) || final_step) &&
             next_sample * dt_sample <= t_new * (1 + 1e-13)) {
        const double ts = next_sample * dt_sample, s = std::clamp((ts - t) / (t_new - t), 0.0, 1.0);
        const double h00 = (1 + 2 * s) * (1 - s) * (1 - s), h10 = s * (1 - s) * (1 - s);
        const double h01 = s * s * (3 - 2 * s), h11 = s * s * (s - 1);
        const double hs = t_new - t;
        record(ts, h00 * y + h10 * hs * k1 + h01 * y_new + h11 * hs * k7);
        ++next_sample;
      }
      t = t_new;
      y = y_new;
      k1 = k7;
      ++res.steps;
      sys.history().push(t, y.head<12>(), k1.head<12>());
      sys.history().forget_before(t - ctrl.max_latency() - T);
      const double lim = o.max_pitch_deg * 3.14159265358979323846 / 180;
      if (std::abs(y(10)) > lim || std::abs(y(9)) > lim) {
        res.completed = false;
        res.stop_reason = fmt::format("the attitude left the envelope at t = {:.4f} s ({:.2f} wingbeats): pitch {:.1f} "
                                      "deg, roll {:.1f} deg (limit {} deg)",
                                      t, t / T, y(10) * 180 / 3.14159265358979323846,
                                      y(9) * 180 / 3.14159265358979323846, o.max_pitch_deg);
      }
      h *= std::clamp(0.9 * std::pow(std::max(e, 1e-10), -0.2), 0.2, 5.0);
    }
    if (o.progress) o.progress(beat + 1, total_beats);
  }
  res.rhs_evaluations = dyn.evaluations() - evals0;
  res.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

GrowthEstimate wingbeat_growth(const FlightResult& r, const ReferenceOrbit& reference, const ReferenceQuantities& ref,
                               double T, const std::vector<int>& states, int first) {
  GrowthEstimate g;
  auto scale = [&](int i) {
    return i >= 3 && i < 6 ? 1 / ref.U : (i >= 6 && i < 9 ? ref.c / ref.U : (i < 3 ? 1 / ref.c : 1.0));
  };
  std::vector<BodyStateVector> sum;
  std::vector<int> count;
  for (const FlightSample& s : r.samples) {
    const int k = std::min(int(std::floor(s.t / T + 1e-9)), int(std::floor(r.samples.back().t / T - 1e-9)));
    if (k < 0) continue;
    if (std::size_t(k) >= g.deviation.size()) {
      g.deviation.resize(std::size_t(k) + 1, 0.0);
      sum.resize(std::size_t(k) + 1, BodyStateVector::Zero());
      count.resize(std::size_t(k) + 1, 0);
    }
    const BodyStateVector d = s.x - reference.state(s.t);
    double m = 0;
    for (int i : states) m = std::max(m, std::abs(d(i)) * scale(i));
    g.deviation[std::size_t(k)] = std::max(g.deviation[std::size_t(k)], m);
    // The wingbeat's mean: its samples from its start to before its end (the closing sample belongs to the last).
    if (s.t < (k + 1) * T * (1 - 1e-12)) {
      sum[std::size_t(k)] += d;
      ++count[std::size_t(k)];
    }
  }
  const int n = int(g.deviation.size());
  g.mean_deviation.assign(std::size_t(n), 0.0);
  for (int k = 0; k < n; ++k)
    for (int i : states)
      if (count[std::size_t(k)] > 0)
        g.mean_deviation[std::size_t(k)] =
            std::max(g.mean_deviation[std::size_t(k)], std::abs(sum[std::size_t(k)](i)) / count[std::size_t(k)] * scale(i));
  g.last = n - 1;
  g.first = first >= 0 ? std::max(0, std::min(first, g.last - 1)) : n / 2;  // a one-wingbeat flight: 0, not -1
  auto slope = [&](const std::vector<double>& dev) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int cnt = 0;
    for (int k = g.first; k <= g.last; ++k) {
      if (!(dev[std::size_t(k)] > 0)) continue;
      const double y = std::log(dev[std::size_t(k)]);
      sx += k, sy += y, sxx += double(k) * k, sxy += k * y;
      ++cnt;
    }
    return cnt >= 2 ? (cnt * sxy - sx * sy) / (cnt * sxx - sx * sx) : std::nan("");
  };
  g.per_wingbeat = slope(g.deviation);
  g.mean_per_wingbeat = slope(g.mean_deviation);
  return g;
}

}  // namespace flapstab
