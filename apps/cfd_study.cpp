// Stability from the Navier-Stokes model (cfd_study.hpp).
#include "apps/cfd_study.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <ostream>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "apps/results_json.hpp"
#include "apps/stability_json.hpp"
#include "cfd/aero_factory.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "cfd/navier_stokes/run.hpp"
#include "core/errors.hpp"
#include "stability/analysis.hpp"
#include "trim/refine.hpp"

namespace flapstab {

namespace {

using clock_type = std::chrono::steady_clock;

const char* row_names = "XYZLMN";
const char* col_names[6] = {"u", "v", "w", "p", "q", "r"};

// Before any CFD run: every derivative column must move the loads by well more than the periodic convergence
// resolves. Predicted change of column j: max over rows of |dW_i/dx_j h_j| / scale_i (scale: weight, weight x c);
// it must reach 10 x perturbation_tolerance (the converged differences then carry at most ~10 % of error).
void check_resolution(const Case& c, const DerivativeResult& qs, const std::vector<int>& columns) {
  const double W = c.insect.weight(), tol = c.aero.cfd.perturbation_tolerance;
  // Velocity columns and rate columns separately: each has its own step (relative_step, relative_rate_step).
  for (const bool rates : {false, true}) {
    std::string bad;
    double worst = 1e300;
    for (int j : columns) {
      if ((j >= 3) != rates) continue;
      const double h = rates ? qs.rate_step : qs.velocity_step;
      double r = 0;
      for (int i = 0; i < 6; ++i)
        r = std::max(r, std::abs(qs.si(i, j) * h) / (i < 3 ? W : W * c.insect.wing.mean_chord));
      if (r < 10 * tol) {
        bad += fmt::format("{}{}: {:.3g} of the weight", bad.empty() ? "" : ", ", col_names[j], r);
        worst = std::min(worst, r);
      }
    }
    if (bad.empty()) continue;
    const bool own = rates && c.derivatives.relative_rate_step > 0;
    const std::string key = own ? "relative_rate_step" : "relative_step";
    const double step = own ? c.derivatives.relative_rate_step : c.derivatives.relative_step;
    throw InputError(c.path, "derivatives." + key,
                     fmt::format("the step {:g} is too small for the CFD runs to resolve: the largest load change the "
                                 "quasi-steady model predicts per column ({}) is below 10 x "
                                 "aero.cfd.perturbation_tolerance = {:.3g}",
                                 step, bad, 10 * tol),
                     fmt::format("{} >= {:.3g}, or a smaller aero.cfd.perturbation_tolerance", key,
                                 step * 10 * tol / worst));
  }
}

// Upper bound of each derivative's standard error from the two runs of its column: a run's standard error of the
// mean difference (CfdRunRecord::final_change, fractions of W for forces and W c for moments, all three components
// together) bounds each component's; the central difference's is sqrt(s+^2 + s-^2) / (2 h).
// Column j's two runs, at +h and -h of its variable (the base kinematics, no other motion), as the table paired
// them; nullptr where one is missing.
using RunPair = std::pair<const ns::CfdRunRecord*, const ns::CfdRunRecord*>;
RunPair column_runs(const std::vector<ns::CfdRunRecord>& runs, int j, double h) {
  const ns::CfdRunRecord *plus = nullptr, *minus = nullptr;
  for (const auto& r : runs) {
    if (r.other_kinematics || r.cycles.empty()) continue;
    const Vec3& x = j < 3 ? r.motion.velocity : r.motion.rate;
    const Vec3& y = j < 3 ? r.motion.rate : r.motion.velocity;
    if (y.squaredNorm() != 0) continue;
    Vec3 e = Vec3::Zero();
    e(j % 3) = h;
    if ((x - e).norm() <= 1e-12 * h) plus = &r;
    if ((x + e).norm() <= 1e-12 * h) minus = &r;
  }
  return {plus, minus};
}

void standard_errors(DerivativeResult& d, const std::vector<ns::CfdRunRecord>& runs, const std::vector<int>& columns,
                     double weight, double chord) {
  const auto& ref = d.table.reference;
  for (int j : columns) {
    const double h = j < 3 ? d.velocity_step : d.rate_step;
    const auto [p, q] = column_runs(runs, j, h);
    const double sp = p ? p->final_change() : -1, sm = q ? q->final_change() : -1;
    if (sp < 0 || sm < 0) continue;
    const double s = std::hypot(sp, sm) / (2 * h);  // per unit of the column variable, in units of the scale
    for (int i = 0; i < 6; ++i) {
      const double scale = i < 3 ? weight : weight * chord, load = i < 3 ? ref.force_scale() : ref.moment_scale();
      const double var = j < 3 ? ref.U : ref.U / ref.c;
      d.standard_error_nd(i, j) = s * scale * var / load;
    }
  }
}

FloquetAnalysis floquet_of(const PhaseDerivatives& ph, const std::string& name, const std::vector<int>& idx,
                           const std::vector<std::string>& states) {
  const PeriodicMatrixSpline A(ph.period, ph.system_samples(idx));
  const MonodromyResult m = monodromy([&](double t) { return A(t); }, Eigen::Index(idx.size()), ph.period);
  return floquet_analysis(name, states, m.monodromy, ph.period, nondimensional_state_scale(states, ph.reference),
                          ph.reference);
}

std::string fmt_c(std::complex<double> z) {
  if (std::abs(z.imag()) < 1e-12) return fmt::format("{:+.4f}", z.real());
  return fmt::format("{:+.4f} {} {:.4f}i", z.real(), z.imag() < 0 ? "-" : "+", std::abs(z.imag()));
}

// "Floquet multipliers of the CFD A(t)<what>, <name> [states]: mu (|mu|, growth ln|mu| per wingbeat[, period
// 2 pi / arg mu wingbeats]); ...", one line; a conjugate pair's period once, with its member of positive arg.
std::string floquet_markdown(const FloquetAnalysis& f, const std::string& what) {
  std::string m = fmt::format("\nFloquet multipliers of the CFD A(t){}, {} [{}]:", what, f.name,
                              fmt::join(f.state_order, ", "));
  for (const auto& mu : f.multipliers) {
    const double arg = std::arg(mu);
    m += fmt::format(" {} (|mu| {:.4f}, {:+.4f} per wingbeat{});", fmt_c(mu), std::abs(mu), std::log(std::abs(mu)),
                     arg > 1e-12 ? fmt::format(", period {:.1f} wingbeats", 2 * std::numbers::pi / arg)
                                 : std::string());
  }
  return m + "\n";
}

}  // namespace

void quasi_steady_start(const Case& c, const AeroModel& qs_model, TrimResult& trim, DerivativeResult& derivatives) {
  Case qc = c;
  qc.aero.model = "quasi-steady";
  trim = trim_hover(qc, qs_model);
  if (!trim.converged)
    throw SolveError(fmt::format("{}: the quasi-steady trim that starts the CFD trim did not converge ({})", c.path,
                                 trim.message));
  const std::vector<int> columns = derivative_columns(c.derivatives.columns);
  derivatives = cycle_averaged_derivatives(qs_model, c.insect, trim.kinematics, c.fluid, c.derivatives.relative_step,
                                           {}, columns, c.derivatives.relative_rate_step);
  check_resolution(c, derivatives, columns);
}

std::vector<MechanismSplit> split_by_mechanism(const DerivativeResult& d, const std::vector<ns::CfdRunRecord>& runs,
                                               const std::vector<int>& columns) {
  std::vector<MechanismSplit> out;
  const auto& ref = d.table.reference;
  for (int j : columns) {
    if (j >= 3) continue;  // rate columns: the grid turns, the partition does not hold
    const double h = d.velocity_step;
    const auto [p, q] = column_runs(runs, j, h);
    if (!p || !q || !p->partition || !q->partition) continue;
    const ns::PartitionMeans *plus = &*p->partition, *minus = &*q->partition;
    if (plus->components != minus->components) continue;
    for (std::size_t k = 0; k < plus->components.size(); ++k) {
      const int i = plus->components[k];
      // per unit of the column variable (N or N m per m/s), then non-dimensional as the table
      const double scale = ref.U / (i < 3 ? ref.force_scale() : ref.moment_scale()) / (2 * h);
      auto nd = [&](int t) { return (plus->values[k][std::size_t(t)] - minus->values[k][std::size_t(t)]) * scale; };
      MechanismSplit m;
      m.row = i;
      m.column = j;
      m.total = d.table.nd(i, j);
      m.pressure = nd(ns::PartitionMeans::pressure);
      m.kinematic = nd(ns::PartitionMeans::kinematic);
      m.centripetal = nd(ns::PartitionMeans::centripetal);
      m.vortex = nd(ns::PartitionMeans::vortex);
      m.viscous = nd(ns::PartitionMeans::viscous);
      m.outer = nd(ns::PartitionMeans::outer);
      m.run_pressure = nd(ns::PartitionMeans::run_pressure);
      m.friction = nd(ns::PartitionMeans::run_friction);
      m.pressure_forced = nd(ns::PartitionMeans::pressure_forced);
      out.push_back(m);
    }
  }
  return out;
}

std::optional<std::string> rate_step_warning(const Case& c, double rate_step, double frequency_hz) {
  // A steady rate turns the body (and the grid fixed to it) through the air: over the several wingbeats of a run
  // a large turn is no longer a small perturbation of the hover.
  const double turn = rate_step / frequency_hz * 180 / 3.14159265358979323846;
  if (!(turn > 5)) return std::nullopt;
  const double h = c.derivatives.relative_rate_step > 0 ? c.derivatives.relative_rate_step : c.derivatives.relative_step;
  return fmt::format(
      "the rate step ({:.4g} rad/s) turns the body {:.1f} deg per wingbeat, {:.0f} deg over a run of {} wingbeats: "
      "not a small perturbation of the hover (docs/theory/cfd-stability.md, \"The rate step\"); [derivatives] "
      "relative_rate_step = {:.3g} gives 5 deg per wingbeat",
      rate_step, turn, turn * c.aero.cfd.max_cycles, c.aero.cfd.max_cycles, h * 5 / turn);
}

namespace {

// [derivatives.pitch_oscillation] as the CFD model's spec: one builder for the plan and the run.
ns::PitchOscillationSpec oscillation_spec(const DerivativeSettings::PitchOscillation& po) {
  ns::PitchOscillationSpec spec;
  spec.amplitude = po.amplitude_deg * std::numbers::pi / 180;
  spec.period_wingbeats = po.period_wingbeats;
  spec.periods = po.periods;
  spec.transient_wingbeats = po.transient_wingbeats;
  return spec;
}

}  // namespace

PitchOscillationStudy pitch_oscillation_study(const ns::PitchOscillationResult& run, const DerivativeTable& table) {
  PitchOscillationStudy p;
  p.run = run;
  const ReferenceQuantities& ref = table.reference;
  const double tc = ref.time_scale();  // c / U: q = q+ / tc
  p.omega_nd = run.omega * tc;
  for (int i = 0; i < 6; ++i) {
    const double scale = i < 3 ? ref.force_scale() : ref.moment_scale();
    const ns::OscillationFit &f = run.fit[std::size_t(i)], &l = run.last_period[std::size_t(i)];
    const std::size_t k = std::size_t(i);
    p.rate_nd[k] = f.rate / (scale * tc);
    p.rate_se_nd[k] = f.rate_se < 0 ? -1 : f.rate_se / (scale * tc);
    p.rate_last_nd[k] = l.rate / (scale * tc);
    p.theta_nd[k] = f.theta / scale;
    p.theta_se_nd[k] = f.theta_se < 0 ? -1 : f.theta_se / scale;
    p.theta_last_nd[k] = l.theta / scale;
  }
  if (!run.phase.empty()) {
    std::array<double, 6> rate{}, theta{};
    const double m = double(run.phase.size());
    for (const auto& at : run.phase)
      for (std::size_t k = 0; k < 6; ++k) {
        const double scale = k < 3 ? ref.force_scale() : ref.moment_scale();
        rate[k] += at[k].rate / (scale * tc) / m;
        theta[k] += at[k].theta / scale / m;
      }
    p.rate_phase_mean_nd = rate;
    p.theta_phase_mean_nd = theta;
  }
  if (table.has_longitudinal) {
    p.modes_steady_rate = analyse_modes(longitudinal_system(table), ref);
    DerivativeTable t = table;
    for (int i : {0, 2, 4}) t.nd(i, 4) = p.rate_nd[std::size_t(i)];
    StateSpace sys = longitudinal_system(t);
    // The aerodynamic attitude derivatives join gravity in the theta column: X+ / m+, Z+ / m+, M+ / Iy+.
    const NonDimensionalParameters q = nondimensional_parameters(t);
    sys.A(0, 3) += p.theta_nd[0] / q.m;
    sys.A(1, 3) += p.theta_nd[2] / q.m;
    sys.A(2, 3) += p.theta_nd[4] / q.Iyy;
    p.modes = analyse_modes(sys, ref);
  }
  return p;
}

CfdStudy cfd_study(const Case& c, const std::string& cache, std::ostream* log,
                   std::shared_ptr<const ns::Decomposition> ranks) {
  const auto t0 = clock_type::now();
  CfdStudy s;
  auto stage = [&](const std::string& name, clock_type::time_point since, int runs) {
    s.stages.push_back({name, std::chrono::duration<double>(clock_type::now() - since).count(), runs});
  };
  // 1. Quasi-steady trim and derivatives: the start and the resolution check.
  Case qc = c;
  qc.aero.model = "quasi-steady";
  const auto qs_model = make_aero_model(qc);
  auto t = clock_type::now();
  const std::vector<int> columns = derivative_columns(c.derivatives.columns);
  const int derivative_runs = 2 * int(columns.size());
  quasi_steady_start(c, *qs_model, s.qs_trim, s.qs_at_start);
  stage("quasi-steady trim and derivatives", t, 0);

  // 2. The plan: grid, cost of a step, runs and wingbeats.
  // The derivative runs' far fields (|V| + |Omega| r) enter the fixed step's CFL estimate.
  std::vector<BodyMotion> motions{BodyMotion{}};
  for (int j : columns) {
    BodyMotion m;
    (j < 3 ? m.velocity : m.rate)(j % 3) = j < 3 ? s.qs_at_start.velocity_step : s.qs_at_start.rate_step;
    motions.push_back(m);
  }
  s.plan = ns::plan_cfd(c, trim_extreme_kinematics(c, s.qs_trim), motions);
  if (std::any_of(columns.begin(), columns.end(), [](int j) { return j >= 3; }))
    if (auto w = rate_step_warning(c, s.qs_at_start.rate_step, s.qs_trim.kinematics.frequency_hz))
      s.plan.warnings.push_back(*w);
  for (const auto& w : s.plan.warnings) {
    if (log) *log << "cfd study: warning: " << w << "\n";
    s.notices.push_back("CFD plan: " + w);
  }
  if (s.plan.steps_per_cycle <= 0)
    throw InputError(c.path, "aero.cfd.steps_per_cycle",
                     "the CFD stability chain runs periodic wingbeats with a fixed, phase-locked time step; none is set",
                     "steps_per_cycle = N, e.g. 400");
  ns::CfdRunOptions dry;
  dry.dry_run = true;
  const ns::CfdResult d = ns::run_cfd(c, s.qs_trim.kinematics, BodyMotion{}, dry);
  s.cells = ns::plan_grid(s.plan).cells();  // the campaign's grid holds every trim kinematics: scale the timing
  s.seconds_per_step_estimate = d.seconds_per_step_estimate * double(s.cells) / double(d.cells);
  const CfdSettings& cs = c.aero.cfd;
  const int runs_max = 1 + cs.trim_iterations + derivative_runs;
  const int typical = std::max(2, cs.cycles) + cs.max_cycles / 2 + 3 * (cs.trim_iterations / 2 + derivative_runs);
  const int most = cs.max_cycles * (2 + cs.trim_iterations + derivative_runs);
  const double per_cycle = s.seconds_per_step_estimate * s.plan.steps_per_cycle;
  if (log)
    *log << fmt::format(
        "cfd study: {} ({}), grid {} cells ({:.1f} per mean chord), {} steps per wingbeat, {:.3g} s per step: up to {} "
        "CFD runs (the hover, <= {} trim iterations, {} derivative runs for the {} columns) of 2 to {} wingbeats each "
        "plus the continued hover; about {} wingbeats = {} (at most {} wingbeats = {}). Finished runs are kept in {}\n",
        c.insect.name, c.path, s.cells, s.plan.chord_cells, s.plan.steps_per_cycle, s.seconds_per_step_estimate,
        runs_max, cs.trim_iterations, derivative_runs, c.derivatives.columns, cs.max_cycles, typical,
        ns::fmt_seconds(typical * per_cycle), most, ns::fmt_seconds(most * per_cycle),
        cache.empty() ? std::string("memory only") : cache)
         << std::flush;
  if (log && cs.fpm.enabled)
    *log << fmt::format(
        "cfd study: [aero.cfd.fpm]: the continued hover and the velocity runs are force-partitioned ({} samples per "
        "wingbeat) to split the velocity derivatives by mechanism; this raises their cost by a factor the estimate "
        "above leaves out (`flapstab cfd {} --dry-run` prints it; 1.3-1.4 on the hawkmoth example)\n",
        cs.fpm.samples_per_cycle, c.path);

  check_pitch_oscillation(c);  // a case built in code has not been through load_case
  if (const auto& po = c.derivatives.pitch_oscillation; po.enabled) {
    const int wb = oscillation_spec(po).wingbeats();
    if (log)
      *log << fmt::format("cfd study: then a forced pitch oscillation of {:g} deg, {} wingbeats per period: {} "
                          "wingbeats beside the continued hover, up to {} more\n",
                          po.amplitude_deg, po.period_wingbeats, wb, ns::fmt_seconds(2 * wb * per_cycle))
           << std::flush;
  }

  // 3. CFD trim from the quasi-steady one.
  ns::CfdModel cfd(c, log, cache);
  cfd.run_over(std::move(ranks));
  cfd.plan_for(trim_extreme_kinematics(c, s.qs_trim));
  t = clock_type::now();
  std::size_t before = 0;
  s.trim = refine_trim(c, cfd, *qs_model, s.qs_trim, RefineSettings{cs.trim_tolerance, cs.trim_iterations}, log);
  stage("hover from rest and CFD trim", t, int(cfd.records().size() - before));
  if (!s.trim.converged) s.notices.push_back("CFD trim: " + s.trim.message);

  // 4. CFD derivatives at the CFD trim, and the phase-resolved A(t) from the same runs.
  before = cfd.records().size();
  t = clock_type::now();
  // The runs one by one first: one that fails (diverges) does not stop the others, so a rerun finds every other
  // run finished (kept in the cache); the columns whose two runs finished are printed before the study stops.
  {
    const std::vector<DerivativeRunFailure> failures =
        make_derivative_runs(cfd, c.insect, s.trim.kinematics, c.fluid, c.derivatives.relative_step,
                             c.derivatives.relative_rate_step, columns, log);
    std::vector<std::string> failed;
    std::vector<int> finished;
    for (const auto& f : failures) failed.push_back(f.message);
    for (int j : columns)
      if (std::none_of(failures.begin(), failures.end(), [j](const DerivativeRunFailure& f) { return f.column == j; }))
        finished.push_back(j);
    if (!failed.empty()) {
      std::string done;
      if (!finished.empty()) {
        // From the finished runs only (the model returns them without running again).
        const DerivativeResult part = cycle_averaged_derivatives(cfd, c.insect, s.trim.kinematics, c.fluid,
                                                                 c.derivatives.relative_step, {}, finished,
                                                                 c.derivatives.relative_rate_step);
        for (int j : finished)
          for (int i : {0, 1, 2, 3, 4, 5})
            if ((j == 0 || j == 2 || j == 4) == (i == 0 || i == 2 || i == 4))  // the column's own plane
              done += fmt::format("{}{} = {:+.4g}", done.empty() ? "" : ", ", derivative_name(i, j), part.table.nd(i, j));
      }
      throw SolveError(fmt::format(
          "cfd study: {} of the {} derivative runs failed:\n  {}\nThe finished runs are kept in {}; a rerun of the same "
          "command reuses them and resumes a failed run from its last whole wingbeat.{}",
          failed.size(), 2 * columns.size(), fmt::join(failed, "\n  "), cache.empty() ? std::string("memory only") : cache,
          done.empty() ? std::string()
                       : fmt::format("\nNon-dimensional derivatives of the columns whose runs finished (no table is "
                                     "written): {}", done)));
    }
  }
  s.derivatives = cycle_averaged_derivatives(cfd, c.insect, s.trim.kinematics, c.fluid, c.derivatives.relative_step,
                                             {}, columns, c.derivatives.relative_rate_step);
  s.derivatives.table.source = "flapstab CFD cycle-averaged derivatives (navier-stokes-ib), from the kept hover state";
  s.phase = phase_resolved_from_runs(cfd, c.insect, s.trim.kinematics, s.derivatives.table.reference,
                                     c.derivatives.relative_step, std::nullopt, columns,
                                     c.derivatives.relative_rate_step);
  stage(fmt::format("CFD derivatives ({} runs) and phase-resolved A(t)", derivative_runs), t,
        int(cfd.records().size() - before));
  s.qs = cycle_averaged_derivatives(*qs_model, c.insect, s.trim.kinematics, c.fluid, c.derivatives.relative_step, {},
                                    columns, c.derivatives.relative_rate_step);
  standard_errors(s.derivatives, cfd.records(), columns, c.insect.weight(), c.insect.wing.mean_chord);
  s.by_mechanism = split_by_mechanism(s.derivatives, cfd.records(), columns);
  if (c.aero.cfd.fpm.enabled && s.by_mechanism.empty())
    s.notices.push_back(
        "[aero.cfd.fpm]: no velocity derivative is split by mechanism: the table has no velocity column, or its runs "
        "were not partitioned (a CFD trim moved the kinematics away from the kept hover's; runs of other kinematics "
        "are not split)");
  for (const auto& r : cfd.records()) {
    if (!r.converged)
      s.notices.push_back(fmt::format("CFD run '{}' did not converge in {} wingbeats (last change {:.3g})", r.label,
                                      r.cycles.size(), r.final_change()));
    // A small standard error does not say the difference has stopped changing: a steady trend across the window
    // (the slow part of the response to a pitch rate, docs/theory/cfd-stability.md) makes the window's mean depend
    // on when the run stopped. Told apart from scatter with three wingbeats in the window or more (with two, the
    // drift is twice the standard error).
    const std::size_t window = r.cycles.size() - r.cycles.size() / 2;
    if (window >= 3 && r.final_drift() > c.aero.cfd.perturbation_tolerance)
      s.notices.push_back(fmt::format(
          "CFD run '{}' still drifts: the trend of its difference from the hover changes it by {:.3g} of the weight "
          "(moments: of weight x mean chord) across its averaging window, more than perturbation_tolerance {:g}; its "
          "derivatives depend on how long it ran", r.label, r.final_drift(), c.aero.cfd.perturbation_tolerance));
  }

  // 5. Floquet analysis of the CFD A(t).
  try {
    if (s.derivatives.table.has_longitudinal)
      s.floquet_longitudinal = floquet_of(s.phase, "longitudinal", {0, 2, 4, 7}, {"u", "w", "q", "theta"});
    if (s.derivatives.table.has_lateral)
      s.floquet_lateral = floquet_of(s.phase, "lateral", {1, 3, 5, 6}, {"v", "p", "r", "phi"});
  } catch (const std::exception& e) {
    s.notices.push_back(std::string("Floquet analysis of the CFD A(t) failed: ") + e.what());
  }
  // 6. The forced pitch oscillation: the rate and attitude columns at one frequency.
  if (const auto& po = c.derivatives.pitch_oscillation; po.enabled) {
    t = clock_type::now();
    const ns::PitchOscillationSpec spec = oscillation_spec(po);
    s.pitch_oscillation = pitch_oscillation_study(cfd.pitch_oscillation(c.insect, s.trim.kinematics, spec),
                                                  s.derivatives.table);
    stage(fmt::format("pitch oscillation ({} wingbeats)", spec.wingbeats()), t, 1);
    auto& ps = *s.pitch_oscillation;
    // Floquet with the oscillation's phase-resolved columns: its steps are the runs' phase-locked rows, step i at
    // phase (i + 1) / n, and the A(t)'s sample k (at phase k / n) is row k - 1 (history_from_rows).
    const std::size_t N = s.phase.samples.size();
    if (ps.run.phase.empty()) {
      ps.floquet_note = ps.run.phase_note;
    } else if (ps.run.phase.size() != N) {
      ps.floquet_note = fmt::format("the oscillation has {} steps per wingbeat, the A(t) {} samples",
                                    ps.run.phase.size(), N);
    } else if (s.derivatives.table.has_longitudinal) {
      std::vector<WrenchColumn> rate(N), theta(N);
      for (std::size_t k = 0; k < N; ++k)
        for (std::size_t i = 0; i < 6; ++i) {
          rate[k](Eigen::Index(i)) = ps.run.phase[(k + N - 1) % N][i].rate;
          theta[k](Eigen::Index(i)) = ps.run.phase[(k + N - 1) % N][i].theta;
        }
      try {
        ps.floquet = floquet_of(with_pitch_columns(s.phase, cfd, c.insect, s.trim.kinematics, rate, theta),
                                "longitudinal", {0, 2, 4, 7}, {"u", "w", "q", "theta"});
      } catch (const std::exception& e) {
        ps.floquet_note = e.what();
      }
    } else {
      ps.floquet_note = "the table has no longitudinal columns";
    }
    if (!ps.floquet)
      s.notices.push_back("pitch oscillation: no Floquet analysis with its columns: " + ps.floquet_note);
    for (int i : {0, 2, 4}) {
      const std::size_t k = std::size_t(i);
      const double se = ps.rate_se_nd[k];
      if (se >= 0 && std::abs(ps.rate_last_nd[k] - ps.rate_nd[k]) > 2 * se && ps.run.spec.periods > 1)
        s.notices.push_back(fmt::format(
            "pitch oscillation: {}q of the last period alone ({:+.4g}) differs from the fit over all {} periods "
            "({:+.4g} ± {:.2g}) by more than twice its standard error: the response may not be periodic yet (more "
            "transient_wingbeats or periods)",
            row_names[i], ps.rate_last_nd[k], ps.run.spec.periods, ps.rate_nd[k], se));
    }
  }
  s.history = cfd.run(c.insect, s.trim.kinematics, BodyMotion{}, AeroRunOptions{});
  s.runs = cfd.records();
  s.reference = cfd.reference_cycles();
  s.wall_time_s = std::chrono::duration<double>(clock_type::now() - t0).count();
  return s;
}

namespace {

nlohmann::json floquet_json(const std::optional<FloquetAnalysis>& f) {
  using nlohmann::json;
  if (!f) return nullptr;
  json mu = json::array(), ex = json::array();
  for (std::size_t i = 0; i < f->multipliers.size(); ++i) {
    mu.push_back({f->multipliers[i].real(), f->multipliers[i].imag()});
    ex.push_back({f->exponents_per_wingbeat[i].real(), f->exponents_per_wingbeat[i].imag()});
  }
  return {{"states", f->state_order}, {"multipliers", mu}, {"exponents_per_wingbeat", ex}};
}

nlohmann::json pitch_oscillation_json(const PitchOscillationStudy& p) {
  using nlohmann::json;
  const ns::PitchOscillationSpec& sp = p.run.spec;
  json wb = json::array();
  for (std::size_t k = 0; k < p.run.wingbeats.size(); ++k) {
    const auto& w = p.run.wingbeats[k];
    wb.push_back({{"wingbeat", k + 1}, {"theta_rad", w.theta}, {"q_rad_s", w.rate},
                  {"dF_N", {w.difference.force.x(), w.difference.force.y(), w.difference.force.z()}},
                  {"dM_N_m", {w.difference.moment.x(), w.difference.moment.y(), w.difference.moment.z()}}});
  }
  json der = json::object();
  for (int i : {0, 2, 4}) {
    const std::size_t k = std::size_t(i);
    der[std::string(1, row_names[i]) + "q"] = {{"value", p.rate_nd[k]}, {"standard_error", p.rate_se_nd[k]},
                                               {"last_period", p.rate_last_nd[k]}};
    der[std::string(1, row_names[i]) + "theta"] = {{"value", p.theta_nd[k]}, {"standard_error", p.theta_se_nd[k]},
                                                   {"last_period", p.theta_last_nd[k]}};
    if (p.rate_phase_mean_nd) {
      der[std::string(1, row_names[i]) + "q"]["phase_resolved_mean"] = (*p.rate_phase_mean_nd)[k];
      der[std::string(1, row_names[i]) + "theta"]["phase_resolved_mean"] = (*p.theta_phase_mean_nd)[k];
    }
  }
  return {{"amplitude_deg", sp.amplitude * 180 / std::numbers::pi},
          {"period_wingbeats", sp.period_wingbeats},
          {"transient_wingbeats", sp.transient()},
          {"periods", sp.periods},
          {"omega_rad_s", p.run.omega},
          {"omega_nd", p.omega_nd},
          {"wall_s", p.run.wall_seconds},
          {"reused", p.run.reused},
          {"derivatives_nd", der},
          {"wingbeats", wb},
          {"modes", p.modes ? to_json(*p.modes) : json()},
          {"modes_steady_rate", p.modes_steady_rate ? to_json(*p.modes_steady_rate) : json()},
          {"floquet_longitudinal", floquet_json(p.floquet)},
          {"floquet_note", p.floquet_note}};
}

}  // namespace

nlohmann::json cfd_study_json(const CfdStudy& s) {
  using nlohmann::json;
  json runs = json::array();
  for (const auto& r : s.runs) {
    json cyc = json::array();
    for (const auto& k : r.cycles)
      cyc.push_back({{"cycle", k.cycle},
                     {"mean_force_N", {k.mean.force.x(), k.mean.force.y(), k.mean.force.z()}},
                     {"mean_moment_N_m", {k.mean.moment.x(), k.mean.moment.y(), k.mean.moment.z()}},
                     {"change", k.change},
                     {"drift", k.drift}});
    runs.push_back({{"label", r.label}, {"cycles", r.cycles.size()}, {"converged", r.converged},
                    {"final_change", r.final_change()}, {"final_drift", r.final_drift()}, {"wall_s", r.wall_seconds},
                    {"reused", r.reused},
                    {"history", cyc}});
  }
  json ref = json::array();
  for (const auto& k : s.reference)
    ref.push_back({{"cycle", k.cycle}, {"mean_force_N", {k.mean.force.x(), k.mean.force.y(), k.mean.force.z()}},
                   {"mean_moment_N_m", {k.mean.moment.x(), k.mean.moment.y(), k.mean.moment.z()}}});
  json by_mechanism = json::array();
  for (const auto& m : s.by_mechanism)
    by_mechanism.push_back({{"derivative", derivative_name(m.row, m.column)}, {"total", m.total},
                            {"run_pressure", m.run_pressure}, {"run_friction", m.friction}, {"pressure", m.pressure},
                            {"added_mass", m.added_mass()}, {"centripetal", m.centripetal}, {"vortex", m.vortex},
                            {"viscous", m.viscous}, {"outer", m.outer}, {"sum", m.sum()},
                            {"pressure_forced", m.pressure_forced}});
  json stages = json::array();
  for (const auto& st : s.stages) stages.push_back({{"stage", st.name}, {"wall_s", st.seconds}, {"cfd_runs", st.runs}});
  return {{"grid", {{"cells", s.cells}, {"cells_per_mean_chord", s.plan.chord_cells},
                    {"fine_spacing_m", s.plan.h_actual}, {"steps_per_cycle", s.plan.steps_per_cycle},
                    {"reynolds", s.plan.reynolds}, {"seconds_per_step_estimate", s.seconds_per_step_estimate},
                    {"sponge_width_m", s.plan.sponge_width}, {"sponge_rate_per_s", s.plan.sponge_rate}}},
          {"quasi_steady_trim", trim_json(s.qs_trim)},
          {"quasi_steady_derivatives", derivatives_json(s.qs)},
          {"runs", runs},
          {"continued_hover", ref},
          {"stages", stages},
          {"phase_resolved", {{"phases", s.phase.samples.size()}, {"cycle_mean_nd", matrix_json(s.phase.mean_wrench_nd())}}},
          {"derivatives_by_mechanism", by_mechanism},
          {"floquet_longitudinal", floquet_json(s.floquet_longitudinal)},
          {"floquet_lateral", floquet_json(s.floquet_lateral)},
          {"pitch_oscillation", s.pitch_oscillation ? pitch_oscillation_json(*s.pitch_oscillation) : json()},
          {"notices", s.notices},
          {"wall_s", s.wall_time_s}};
}

namespace {

std::string pitch_oscillation_markdown(const PitchOscillationStudy& p, const DerivativeTable& cfd,
                                       const DerivativeTable& qs) {
  const ns::PitchOscillationSpec& sp = p.run.spec;
  std::string m = fmt::format(
      "\nForced pitch oscillation (docs/theory/cfd-stability.md): theta = {:.3g} deg x sin(omega t) about O, period {} "
      "wingbeats (omega c/U = {:.4f}), {} wingbeats left out, then {} period{} fitted (wingbeat means of the loads' "
      "difference from the continued hover against those of theta and q), and the cycle mean of the same fit made "
      "phase by phase (each phase-locked step's difference against theta and q at that step). Non-dimensional as the "
      "table; the rate column beside the steady-rate runs' and the quasi-steady model's:\n\n"
      "| derivative | oscillation ± standard error | last period alone | phase-resolved, cycle mean | steady rate "
      "(table) | quasi-steady |\n"
      "|---|---|---|---|---|---|\n",
      sp.amplitude * 180 / std::numbers::pi, sp.period_wingbeats, p.omega_nd, sp.transient(), sp.periods,
      sp.periods == 1 ? "" : "s");
  auto se = [](double v) { return v >= 0 ? fmt::format(" ± {:.4f}", v) : std::string(); };
  auto phase_mean = [](const std::optional<std::array<double, 6>>& v, std::size_t k) {
    return v ? fmt::format("{:+.4f}", (*v)[k]) : std::string("-");
  };
  for (int i : {0, 2, 4}) {
    const std::size_t k = std::size_t(i);
    m += fmt::format("| {}q | {:+.4f}{} | {:+.4f} | {} | {:+.4f} | {:+.4f} |\n", row_names[i], p.rate_nd[k],
                     se(p.rate_se_nd[k]), p.rate_last_nd[k], phase_mean(p.rate_phase_mean_nd, k), cfd.nd(i, 4),
                     qs.nd(i, 4));
  }
  for (int i : {0, 2, 4}) {
    const std::size_t k = std::size_t(i);
    m += fmt::format("| {}θ (per rad) | {:+.4f}{} | {:+.4f} | {} | (0: a steady attitude changes nothing in still "
                     "air) | 0 |\n", row_names[i], p.theta_nd[k], se(p.theta_se_nd[k]), p.theta_last_nd[k],
                     phase_mean(p.theta_phase_mean_nd, k));
  }
  if (p.modes && p.modes_steady_rate) {
    m += "\nLongitudinal modes with the oscillation's q column and aerodynamic theta column, beside those of the table "
         "with its steady-rate q column (growth per wingbeat Re(lambda)/f; period in wingbeats):\n\n"
         "| mode (oscillation columns) | growth per wingbeat | period | mode (steady-rate table) | growth | period |\n"
         "|---|---|---|---|---|---|\n";
    const auto& a = p.modes->modes;
    const auto& b = p.modes_steady_rate->modes;
    for (std::size_t i = 0; i < std::max(a.size(), b.size()); ++i) {
      auto cell = [](const std::vector<Mode>& v, std::size_t j) {
        if (j >= v.size()) return std::string("| | | ");
        return fmt::format("| {} | {:+.4f} | {} ", v[j].name, v[j].eigenvalue_per_wingbeat.real(),
                           v[j].period_wingbeats ? fmt::format("{:.2f}", *v[j].period_wingbeats) : std::string("-"));
      };
      m += cell(a, i) + cell(b, i) + "|\n";
    }
    for (const Mode& md : a)
      if (md.period_wingbeats) {  // the least damped oscillatory mode (modes come most unstable first)
        const double ratio = *md.period_wingbeats / sp.period_wingbeats;
        m += fmt::format("\nThe {} has a period of {:.2f} wingbeats, {:.2f} x the oscillation's: {}\n", md.name,
                         *md.period_wingbeats, ratio,
                         std::abs(ratio - 1) <= 0.2
                             ? "the derivatives were measured near the mode's own frequency."
                             : fmt::format("derivatives of a lagging wake depend on the frequency; rerun with "
                                           "period_wingbeats = {} for this mode (the next step of a p-k iteration).",
                                           std::max(2, int(std::lround(*md.period_wingbeats)))));
        break;
      }
  }
  if (p.floquet) m += floquet_markdown(*p.floquet, " with the oscillation's phase-resolved q and theta columns");
  return m;
}

}  // namespace

std::string cfd_study_markdown(const CfdStudy& s) {
  std::string m = "## Navier-Stokes (CFD) stability\n\n";
  m += fmt::format("Grid: {} cells, {:.1f} cells per mean chord (fine spacing {:.4g} m), Re = {:.4g}, {} steps per "
                   "wingbeat. Every run starts from one kept periodic hover state; perturbed runs are measured against "
                   "the continued hover.{}\n\n",
                   s.cells, s.plan.chord_cells, s.plan.h_actual, s.plan.reynolds, s.plan.steps_per_cycle,
                   s.plan.sponge_width > 0
                       ? fmt::format(" A sponge layer {:.3g} m deep lines the faces (relaxation rate {:g} per wingbeat "
                                     "at the face).", s.plan.sponge_width, s.plan.sponge_rate * s.plan.period)
                       : std::string());
  m += "| run | wingbeats | converged | final change (of weight) | drift across the window | wall time |\n"
       "|---|---|---|---|---|---|\n";
  for (const auto& r : s.runs)
    m += fmt::format("| {} | {} | {} | {} | {} | {} |\n", r.label, r.cycles.size(), r.converged ? "yes" : "**no**",
                     r.final_change() < 0 ? std::string("-") : fmt::format("{:.2e}", r.final_change()),
                     r.final_drift() < 0 ? std::string("-") : fmt::format("{:.2e}", r.final_drift()),
                     r.reused ? std::string("reused") : ns::fmt_seconds(r.wall_seconds));
  m += "\n| stage | wall time | CFD runs |\n|---|---|---|\n";
  for (const auto& st : s.stages) m += fmt::format("| {} | {} | {} |\n", st.name, ns::fmt_seconds(st.seconds), st.runs);
  m += fmt::format("\nCFD trim ({}): ", s.trim.message);
  for (const auto& p : s.trim.parameters)
    m += fmt::format("{} = {:.3f} {} (quasi-steady {:.3f}); ", p.label, p.value, p.unit, p.initial);
  m += fmt::format("residual force {:.2e} x weight, moment {:.2e} x weight x R.\n\n", s.trim.relative_force_residual,
                   s.trim.relative_moment_residual);
  // The planes the table holds: longitudinal rows X Z M x columns u w q, lateral Y L N x v p r (both: all 36).
  const DerivativeTable& tab = s.derivatives.table;
  std::vector<int> idx;
  for (int k = 0; k < 6; ++k)
    if ((k % 2 == 0 && tab.has_longitudinal) || (k % 2 == 1 && tab.has_lateral)) idx.push_back(k);
  m += "Cycle-averaged derivatives (non-dimensional), CFD ± its standard error (an upper bound from the runs' "
       "scatter) / quasi-steady at the same kinematics, and the CFD linearity asymmetry:\n\n|";
  for (int j : idx) m += fmt::format(" | {}", col_names[j]);
  m += " |\n|---|";
  for (std::size_t j = 0; j < idx.size(); ++j) m += "---|";
  m += "\n";
  for (int i : idx) {
    m += fmt::format("| {} ", row_names[i]);
    for (int j : idx) {
      const double se = s.derivatives.standard_error_nd(i, j);
      m += fmt::format("| {:+.4f}{} / {:+.4f} ({:.0f} %) ", tab.nd(i, j),
                       se >= 0 ? fmt::format(" ± {:.4f}", se) : std::string(), s.qs.table.nd(i, j),
                       100 * s.derivatives.asymmetry(i, j));
    }
    m += "|\n";
  }
  const auto& n = tab.nd;
  if (tab.has_longitudinal)
    m += fmt::format("\nHover pattern (Sun & Xiong 2005; Sun, Wang & Xiong 2007): X_u < 0: {}; M_u > 0: {}; Z_w < 0: "
                     "{}; M_q < 0: {}.\n",
                     n(0, 0) < 0 ? "yes" : "**no**", n(4, 0) > 0 ? "yes" : "**no**", n(2, 2) < 0 ? "yes" : "**no**",
                     n(4, 4) < 0 ? "yes" : "**no**");
  if (!s.by_mechanism.empty()) {
    m += "\nVelocity derivatives split by mechanism (force partitioning of the same runs; non-dimensional as the "
         "table): the table's value (the run's loads at every step), the run's pressure and skin-friction parts at the "
         "partition's samples, the pressure load on the partition's body that the parts should sum to (the parts' "
         "cut cells, or with [aero.cfd.fpm] body = \"forced-region\" the parts widened to the faces the immersed "
         "boundary forces), its parts, their sum and the closure gap (sum minus that pressure) with the pressure on "
         "the faces the immersed boundary forces, which no part accounts for (zero for the widened body). The rate "
         "columns are not split: their grid turns with the body, where the partition does not hold. Kinematic parts "
         "of velocity derivatives vanish in theory (the parts move in the body's frame as in the hover).\n\n"
         "| derivative | table | run's pressure | skin friction | body's pressure | added mass | CAR "
         "| vortex-induced | viscous | outer | sum | closure gap | on the forced faces |\n"
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& b : s.by_mechanism)
      m += fmt::format("| {} | {:+.4f} | {:+.4f} | {:+.4f} | {:+.4f} | {:+.4f} | {:+.4f} | {:+.4f} | {:+.4f} | "
                       "{:+.4f} | {:+.4f} | {:+.4f} | {:+.4f} |\n",
                       derivative_name(b.row, b.column), b.total, b.run_pressure, b.friction, b.pressure,
                       b.added_mass(), b.centripetal, b.vortex, b.viscous, b.outer, b.sum(), b.sum() - b.pressure,
                       b.pressure_forced);
  }
  for (const auto* f : {&s.floquet_longitudinal, &s.floquet_lateral})
    if (*f) m += floquet_markdown(**f, "");
  if (s.pitch_oscillation) m += pitch_oscillation_markdown(*s.pitch_oscillation, s.derivatives.table, s.qs.table);
  for (const auto& note : s.notices) m += "\n- " + note;
  return m + "\n";
}

}  // namespace flapstab
