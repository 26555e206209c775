// Cycle-averaged stability derivatives by central differences over any AeroModel.
#include "cfd/derivatives.hpp"

#include <algorithm>
#include <fmt/format.h>
#include "cfd/phase_derivatives.hpp"
#include "core/configuration.hpp"
#include "core/eom.hpp"
#include "core/errors.hpp"

namespace flapstab {

ReferenceQuantities reference_quantities(const Insect& insect, const Kinematics& kin, const FluidProperties& fluid) {
  ReferenceQuantities r;
  r.U = 2 * kin.stroke_amplitude() * kin.frequency_hz * insect.wing.radius_of_moment(2);
  r.c = insect.wing.mean_chord;
  r.S_t = 2 * insect.wing.area();
  r.rho = fluid.density;
  r.frequency = kin.frequency_hz;
  r.g = insect.gravity;
  return r;
}

MassProperties mass_properties(const Insect& insect, const Kinematics& kin) {
  const Configuration config(insect, kin);
  constexpr int n = 128;
  Mat3 J = Mat3::Zero();
  for (int i = 0; i < n; ++i) {
    const MassState ms = config.mass_state(kin.period() * i / n);
    for (const PartMass* p : ms.parts())
      J += p->mass * (p->r.squaredNorm() * Mat3::Identity() - p->r * p->r.transpose()) + p->inertia;
  }
  J /= n;
  MassProperties m;
  m.m = insect.total_mass();
  m.Ixx = J(0, 0);
  m.Iyy = J(1, 1);
  m.Izz = J(2, 2);
  m.Ixz = -J(0, 2);  // product of inertia int x z dm (the tensor holds -Ixz)
  return m;
}

std::vector<int> derivative_columns(const std::string& set) {
  if (set == "all") return {0, 1, 2, 3, 4, 5};
  if (set == "longitudinal") return {0, 2, 4};
  if (set == "lateral") return {1, 3, 5};
  throw SolveError("derivative_columns: unknown set \"" + set + "\" (all, longitudinal or lateral)");
}

BodyMotion derivative_perturbation(const ReferenceQuantities& ref, double relative_step, double relative_rate_step,
                                   int column, int sign) {
  if (column < 0 || column > 5) throw SolveError("derivatives: column index out of 0..5");
  const double h = column < 3 ? relative_step * ref.U
                              : (relative_rate_step > 0 ? relative_rate_step : relative_step) * ref.U / ref.c;
  BodyMotion m;
  (column < 3 ? m.velocity : m.rate)(column % 3) = sign < 0 ? -h : h;
  return m;
}

std::vector<DerivativeRunFailure> make_derivative_runs(const AeroModel& model, const Insect& insect,
                                                       const Kinematics& kin, const FluidProperties& fluid,
                                                       double relative_step, double relative_rate_step,
                                                       const std::vector<int>& columns, std::ostream* log) {
  const ReferenceQuantities ref = reference_quantities(insect, kin, fluid);
  std::vector<DerivativeRunFailure> failed;
  std::vector<std::pair<int, int>> deferred;  // runs another process is computing: asked for again at the end
  auto make = [&](int j, int sign, bool defer) {
    AeroRunOptions o;
    o.defer_held = defer;
    try {
      model.run(insect, kin, derivative_perturbation(ref, relative_step, relative_rate_step, j, sign), o);
    } catch (const RunHeldElsewhere& e) {
      deferred.emplace_back(j, sign);
      if (log) *log << "derivatives: " << e.what() << "; going on with the next run\n" << std::flush;
    } catch (const SolveError& e) {
      failed.push_back({j, sign, e.what()});
      if (log) *log << "derivatives: " << e.what() << "; the other runs go on\n" << std::flush;
    }
  };
  for (int j : columns)
    for (int sign : {+1, -1}) make(j, sign, true);
  // The runs held elsewhere: waited for (and reused), or made here if their process ended without them.
  const auto held = std::move(deferred);
  for (const auto& [j, sign] : held) make(j, sign, false);
  return failed;
}

namespace {

bool has_columns(const std::vector<int>& columns, std::initializer_list<int> wanted) {
  for (int j : wanted)
    if (std::find(columns.begin(), columns.end(), j) == columns.end()) return false;
  return true;
}

void check_columns(const std::vector<int>& columns) {
  if (columns.empty()) throw SolveError("derivatives: no columns asked for");
  for (int j : columns)
    if (j < 0 || j > 5) throw SolveError("derivatives: column index out of 0..5");
}

}  // namespace

DerivativeResult cycle_averaged_derivatives(const AeroModel& model, const Insect& insect, const Kinematics& kin,
                                            const FluidProperties& fluid, double relative_step,
                                            const AeroRunOptions& run, const std::vector<int>& columns,
                                            double relative_rate_step) {
  check_columns(columns);
  DerivativeResult out;
  DerivativeTable& t = out.table;
  t.reference = reference_quantities(insect, kin, fluid);
  t.mass = mass_properties(insect, kin);
  t.has_longitudinal = has_columns(columns, {0, 2, 4});
  t.has_lateral = has_columns(columns, {1, 3, 5});
  t.has_coupling = t.has_longitudinal && t.has_lateral;
  t.source = "flapstab cycle-averaged derivatives, " + model.name();
  const ReferenceQuantities& ref = t.reference;
  out.velocity_step = relative_step * ref.U;
  out.rate_step = (relative_rate_step > 0 ? relative_rate_step : relative_step) * ref.U / ref.c;
  auto mean = [&](const BodyMotion& m) {
    ++out.model_runs;
    const Wrench w = model.run(insect, kin, m, run).mean();
    Eigen::Matrix<double, 6, 1> v;
    v << w.force, w.moment;
    return v;
  };
  {
    const auto w0 = mean(BodyMotion{});
    out.mean_at_trim.force = w0.head<3>();
    out.mean_at_trim.moment = w0.tail<3>();
  }
  out.si.setZero();
  for (int j : columns) {
    const double h = j < 3 ? out.velocity_step : out.rate_step;
    const auto wp = mean(derivative_perturbation(ref, relative_step, relative_rate_step, j, +1)),
               wm = mean(derivative_perturbation(ref, relative_step, relative_rate_step, j, -1));
    out.si.col(j) = (wp - wm) / (2 * h);
    Eigen::Matrix<double, 6, 1> w0;
    w0 << out.mean_at_trim.force, out.mean_at_trim.moment;
    for (int i = 0; i < 6; ++i) {
      const double den = std::abs(wp(i) - wm(i));
      out.asymmetry(i, j) = den > 0 ? std::abs(wp(i) + wm(i) - 2 * w0(i)) / den : 0.0;
    }
  }
  // Non-dimensional: d(F/(q S_t)) / d(u/U) and d(F/(q S_t)) / d(q c/U); moments also / c.
  for (int i = 0; i < 6; ++i) {
    const double load = i < 3 ? ref.force_scale() : ref.moment_scale();
    for (int j = 0; j < 6; ++j) {
      const double var = j < 3 ? ref.U : ref.U / ref.c;
      t.nd(i, j) = out.si(i, j) * var / load;
    }
  }
  return out;
}

PhaseDerivatives phase_resolved_from_runs(const AeroModel& model, const Insect& insect, const Kinematics& kin,
                                          const ReferenceQuantities& ref, double relative_step,
                                          std::optional<double> g_given, const std::vector<int>& columns,
                                          double relative_rate_step) {
  check_columns(columns);
  const double g = g_given.value_or(insect.gravity);
  if (!(relative_step > 0)) throw SolveError("phase_resolved_from_runs: the relative step must be positive");
  PhaseDerivatives out;
  out.period = kin.period();
  out.relative_step = relative_step;
  out.velocity_step = relative_step * ref.U;
  out.rate_step = (relative_rate_step > 0 ? relative_rate_step : relative_step) * ref.U / ref.c;
  out.reference = ref;
  const WrenchHistory h0 = model.run(insect, kin, BodyMotion{}, AeroRunOptions{});
  const std::size_t N = h0.samples.size();
  if (N < 3) throw SolveError("phase_resolved_from_runs: the model's wingbeat has fewer than 3 samples");
  std::vector<WrenchHistory> plus(6), minus(6);
  for (int j : columns) {
    plus[std::size_t(j)] = model.run(insect, kin, derivative_perturbation(ref, relative_step, relative_rate_step, j, +1),
                                     AeroRunOptions{});
    minus[std::size_t(j)] = model.run(insect, kin, derivative_perturbation(ref, relative_step, relative_rate_step, j, -1),
                                      AeroRunOptions{});
    if (plus[std::size_t(j)].samples.size() != N || minus[std::size_t(j)].samples.size() != N)
      throw SolveError("phase_resolved_from_runs: the runs have different numbers of samples per wingbeat");
    out.load_evaluations += 2;
  }
  const Configuration config(insect, kin);
  for (std::size_t k = 0; k < N; ++k) {
    PhaseSample s;
    s.time = h0.samples[k].time;
    s.state = BodyStateVector::Zero();
    s.wrench_si.setZero();
    const Wrench w0 = h0.samples[k].total();
    for (int j : columns) {
      const double h = j < 3 ? out.velocity_step : out.rate_step;
      const Wrench wp = plus[std::size_t(j)].samples[k].total(), wm = minus[std::size_t(j)].samples[k].total();
      s.wrench_si.col(j).head<3>() = (wp.force - wm.force) / (2 * h);
      s.wrench_si.col(j).tail<3>() = (wp.moment - wm.moment) / (2 * h);
    }
    complete_phase_sample(s, config, w0, ref, g);
    out.samples.push_back(s);
  }
  return out;
}

PhaseDerivatives with_pitch_columns(const PhaseDerivatives& ph, const AeroModel& model, const Insect& insect,
                                    const Kinematics& kin, const std::vector<WrenchColumn>& rate_si,
                                    const std::vector<WrenchColumn>& theta_si, std::optional<double> g_given) {
  const std::size_t N = ph.samples.size();
  if (rate_si.size() != N || theta_si.size() != N)
    throw SolveError(fmt::format("with_pitch_columns: {} phase samples, but {} rate and {} attitude columns", N,
                                 rate_si.size(), theta_si.size()));
  const WrenchHistory h0 = model.run(insect, kin, BodyMotion{}, AeroRunOptions{});
  if (h0.samples.size() != N)
    throw SolveError(fmt::format("with_pitch_columns: the hover has {} samples per wingbeat, the A(t) {}",
                                 h0.samples.size(), N));
  const Configuration config(insect, kin);
  PhaseDerivatives out = ph;
  for (std::size_t k = 0; k < N; ++k) {
    PhaseSample& s = out.samples[k];
    for (int i : {0, 2, 4}) {  // X Z M
      s.wrench_si(i, 4) = rate_si[k](i);
      s.attitude_si(i, 1) = theta_si[k](i);
    }
    complete_phase_sample(s, config, h0.samples[k].total(), ph.reference, g_given.value_or(insect.gravity));
  }
  return out;
}

}  // namespace flapstab
