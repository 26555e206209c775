// flapstab fly and flapstab control-map: free flight and the pitch controller's stability map.
#include "apps/flight_command.hpp"
#include "apps/over_ranks.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "apps/commands.hpp"
#include "apps/plots.hpp"
#include "apps/results_json.hpp"
#include "cfd/aero_factory.hpp"
#include "cfd/navier_stokes/decomposition.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "flight/free_flight.hpp"
#include "flight/hover_model.hpp"

namespace flapstab {

namespace {

using nlohmann::json;

std::string output_dir(const Case& c, const std::string& given) {
  const std::string d = given.empty() ? c.output_directory : given;
  if (d.empty()) throw InputError(c.path, "output.directory", "is empty", "a directory path (or give -o DIR)");
  return d;
}

// Which states a DoF set moves (BodyStateVector indices), for checks and growth estimates.
std::vector<int> moving_states(DofSet d) {
  const std::array<bool, 6> f = free_accelerations(d);
  std::vector<int> s;
  for (int i = 0; i < 6; ++i)
    if (f[std::size_t(i)]) s.push_back(3 + i);
  if (f[3]) s.push_back(9);
  if (f[4]) s.push_back(10);
  if (f[5]) s.push_back(11);
  return s;
}

void require_quasi_steady(const Case& c, const char* command) {
  if (c.aero.model != "quasi-steady")
    throw InputError(c.path, "aero.model",
                     fmt::format("flapstab {} runs on the quasi-steady model (flapstab fly also on model = \"cfd\")", command),
                     "model = \"quasi-steady\"");
}

}  // namespace

// The actuators a controller drives, with their absolute limits (parameter units); the pitch controller's limit
// is relative to trim and set by pitch_controller.
std::vector<TrimParameterSpec> controller_actuators(const Case& c) {
  if (c.control.type == "pitch") return {unbounded_parameter(c.control.actuator)};
  if (c.control.type == "state-feedback") return c.control.actuators;
  return {};
}

ControllerSpec controller_from_case(const Case& c, const Kinematics& kin) {
  ControllerSpec spec;
  if (c.control.type == "pitch") {
    spec = pitch_controller(pitch_controller_settings(c.control), parameter_value(kin, c.control.actuator, c.path));
    validate_controller(spec, c.path, "control.pitch");
  } else if (c.control.type == "state-feedback") {
    spec.actuators = c.control.actuators;
    for (const auto& t : c.control.feedback)
      spec.terms.push_back({t.state, t.actuator, t.gain, t.latency_s, t.filter_time_s});
    spec.update = c.control.update == "wingbeat" ? ControlUpdate::wingbeat : ControlUpdate::continuous;
    spec.description = fmt::format("linear state feedback, {} terms", spec.terms.size());
    validate_controller(spec, c.path, "control.feedback");
  }
  return spec;
}

namespace {

// flapstab fly in this process (`ranks`: the processes mpiexec started, null for one).
int fly(const FlightCommandOptions& o, const std::shared_ptr<const ns::Decomposition>& ranks) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case_for(o.case_path, "fly");
  if (c.aero.model != "cfd") require_quasi_steady(c, "fly");
  const std::string dir = output_dir(c, o.output_dir);
  const DofSet dofs = parse_dof_set(o.dof.empty() ? c.flight.dof : o.dof, o.dof.empty() ? c.path : "--dof",
                                    o.dof.empty() ? "flight.dof" : "");
  const double wingbeats = o.wingbeats > 0 ? o.wingbeats : c.flight.wingbeats;
  const std::vector<int> moving = moving_states(dofs);
  // A perturbation the DoF set cannot carry is refused before any work.
  for (const auto& [name, value] : c.flight.perturbation) {
    const int i = *body_state_index(name);
    const int rate = i < 3 ? i + 3 : (i >= 9 ? i - 3 : i);  // position -> its velocity, angle -> its rate
    if (value != 0 && std::find(moving.begin(), moving.end(), rate) == moving.end())
      throw InputError(c.path, "flight.perturbation", fmt::format("perturbs {}, which the '{}' degrees of freedom "
                                                                  "hold fixed", name, dof_set_name(dofs)),
                       "a perturbation of the states the dof set moves, or another dof");
  }
  if (!c.flight.mode.empty()) {
    if (c.flight.start != "periodic-orbit")
      throw InputError(c.path, "flight.perturbation.mode", "a Floquet mode needs the periodic orbit",
                       "start = \"periodic-orbit\"");
    if (c.flight.mode == "lateral" && dofs != DofSet::six_dof)
      throw InputError(c.path, "flight.perturbation.mode", "a lateral mode needs all six degrees of freedom",
                       "dof = \"6dof\"");
    if (c.flight.mode == "longitudinal" && (dofs == DofSet::pitch || dofs == DofSet::translation))
      throw InputError(c.path, "flight.perturbation.mode",
                       "the longitudinal mode moves u, w, q and theta, which the '" + dof_set_name(dofs) + "' set does not",
                       "dof = \"longitudinal\" or \"6dof\"");
  }
  // Started by mpiexec: every flow of the flight (the hover, the CFD trim's runs, the reference and the perturbed
  // flight) runs over all the processes, the grid in z slabs, as flapstab cfd's does.
  if (c.aero.model == "cfd") return run_fly_cfd(o, c, dir, dofs, wingbeats, moving, ranks);
  // The quasi-steady flight is one process's work: under mpiexec rank 0 flies it and the others end.
  if (ranks && ranks->rank() != 0) return 0;
  const auto model = make_aero_model(c);
  const std::vector<TrimParameterSpec> actuators = controller_actuators(c);

  std::optional<HoverModel> hover;
  Kinematics kin;
  BodyStateVector x0 = BodyStateVector::Zero();
  ReferenceOrbit reference{[](double) { return BodyStateVector::Zero().eval(); }, BodyStateVector::Zero()};
  ReferenceQuantities ref;
  std::complex<double> mode_multiplier = 0;
  if (c.flight.start == "periodic-orbit") {
    hover = hover_model(c, *model, actuators);
    kin = hover->cyclic.kinematics;
    x0 = hover->cyclic.initial_state;
    reference = reference_orbit(hover->orbit, hover->cyclic.period);
    ref = hover->derivatives.table.reference;
    if (!c.flight.mode.empty()) x0 += floquet_mode_perturbation(*hover, c.flight.mode, c.flight.mode_amplitude, &mode_multiplier);
  } else {
    const TrimResult t = trim_hover(c, *model);
    if (!t.converged) throw SolveError(c.path + ": the averaged trim did not converge (" + t.message + ")");
    kin = t.kinematics;
    ref = reference_quantities(c.insect, kin, c.fluid);
  }
  for (const auto& [name, value] : c.flight.perturbation) x0(*body_state_index(name)) += value;
  const ControllerSpec controller = controller_from_case(c, kin);
  const FlightDynamics dyn(*model, c.insect, kin, controller.actuators.empty() ? actuators : controller.actuators, dofs);
  const double T = kin.period();
  if (!o.quiet) {
    fmt::print("{}: free flight of '{}', {} degrees of freedom, {} wingbeats from the {}{}\n", c.path, c.insect.name,
               dof_set_name(dofs), wingbeats, c.flight.start,
               c.flight.mode.empty() ? "" : fmt::format(" along the {} Floquet mode (|mu| = {:.4f})", c.flight.mode,
                                                        std::abs(mode_multiplier)));
    if (!controller.empty()) fmt::print("  controller: {}\n", controller.description);
  }
  FlightOptions fo;
  fo.wingbeats = wingbeats;
  fo.samples_per_wingbeat = c.flight.samples_per_wingbeat;
  fo.rtol = c.flight.rtol;
  const int every = std::max(1, int(wingbeats) / 10);
  if (!o.quiet)
    fo.progress = [&](int k, int n) {
      if (k % every == 0 || k == n) fmt::print("  wingbeat {}/{} ({:.1f} s)\n", k, n, seconds_since(t0));
    };
  const FlightResult r = simulate_flight(dyn, controller, x0, reference, ref, fo);
  const GrowthEstimate growth = wingbeat_growth(r, reference, ref, T, moving);

  // Files: everything is computed first, then each file is written atomically.
  auto column = [](int i) {
    std::string u = body_state_units()[std::size_t(i)];
    std::replace(u.begin(), u.end(), '/', '_');
    return fmt::format("{}_{}", body_state_names()[std::size_t(i)], u);
  };
  std::string csv = "t_s,wingbeat";
  for (int i = 0; i < 12; ++i) csv += fmt::format(",{}", column(i));
  for (int i : {3, 4, 5, 6, 7, 8, 9, 10}) csv += fmt::format(",d{}", column(i));
  csv += ",X_N,Y_N,Z_N,L_N_m,M_N_m,N_N_m,power_W";
  for (const auto& a : dyn.actuators()) csv += fmt::format(",command_{}", a.label());
  csv += "\n";
  for (const FlightSample& s : r.samples) {
    std::vector<double> row{s.t, s.t / T};
    for (int i = 0; i < 12; ++i) row.push_back(s.x(i));
    const BodyStateVector d = s.x - reference.state(s.t);
    for (int i : {3, 4, 5, 6, 7, 8, 9, 10}) row.push_back(c.flight.start == "periodic-orbit" ? d(i) : s.x(i));
    for (int i = 0; i < 3; ++i) row.push_back(s.aero.force(i));
    for (int i = 0; i < 3; ++i) row.push_back(s.aero.moment(i));
    row.push_back(s.power);
    for (std::size_t a = 0; a < dyn.actuators().size(); ++a) row.push_back(a < s.command.size() ? s.command[a] : 0.0);
    csv += fmt::format("{:.10g}\n", fmt::join(row, ","));
  }
  json j = metadata_json(c, "fly");
  json terms = json::array();
  for (const auto& t : controller.terms)
    terms.push_back({{"state", t.state}, {"actuator", t.actuator}, {"gain", t.gain}, {"gain_unit", "actuator unit per SI unit of the state"},
                     {"latency_s", t.latency_s}, {"filter_time_s", t.filter_time_s}});
  j["flight"] = {{"dof", dof_set_name(dofs)},
                 {"wingbeats", wingbeats},
                 {"start", c.flight.start},
                 {"mode", c.flight.mode},
                 {"mode_amplitude_nd", c.flight.mode_amplitude},
                 {"mode_multiplier", {mode_multiplier.real(), mode_multiplier.imag()}},
                 {"samples_per_wingbeat", fo.samples_per_wingbeat},
                 {"rtol", fo.rtol},
                 {"period_s", T},
                 {"initial_state", json::object()},
                 {"integrator", "Dormand-Prince 5(4), steps no longer than the shortest latency; cubic Hermite history"}};
  for (int i = 0; i < 12; ++i) j["flight"]["initial_state"][body_state_names()[std::size_t(i)] + "_" + body_state_units()[std::size_t(i)]] = x0(i);
  j["controller"] = {{"type", c.control.type},
                     {"description", controller.description},
                     {"update", controller.update == ControlUpdate::wingbeat ? "wingbeat" : "continuous"},
                     {"sensed_reference", "the periodic hover orbit at the sensed instant"},
                     {"law", "delta p = clamp(p_trim - sum gain * (x(t - latency) - x_orbit(t - latency)), limits) - p_trim"},
                     {"terms", terms}};
  j["result"] = {{"completed", r.completed},
                 {"stop_reason", r.stop_reason},
                 {"steps", r.steps},
                 {"rejected_steps", r.rejected},
                 {"rhs_evaluations", r.rhs_evaluations},
                 {"simulation_time_s", r.wall_time_s},
                 {"deviation_note", "largest non-dimensional deviation from the periodic orbit within each wingbeat "
                                    "(velocities / U, rates c / U, angles rad) over the moving states"}};
  put_growth(j["result"], growth);
  j["wall_time_s"] = seconds_since(t0);
  LinePlot plot;
  plot.title = c.insect.name + ": free-flight response (" + dof_set_name(dofs) + ")";
  plot.xlabel = "time (wingbeats)";
  plot.ylabel = c.flight.start == "periodic-orbit" ? "deviation from the periodic orbit" : "state";
  Series th{"pitch theta (deg)", {}, {}}, ph{"roll phi (deg)", {}, {}};
  Series cm{dyn.actuators().empty() ? "command" : "command: " + dyn.actuators()[0].label() + " offset (" +
                                                     TrimParameterization::unit(dyn.actuators()[0].name) + ")",
            {}, {}};
  for (const FlightSample& s : r.samples) {
    const BodyStateVector d = c.flight.start == "periodic-orbit" ? BodyStateVector(s.x - reference.state(s.t)) : s.x;
    th.x.push_back(s.t / T);
    th.y.push_back(d(10) / deg);
    ph.x.push_back(s.t / T);
    ph.y.push_back(d(9) / deg);
    if (!s.command.empty()) {
      cm.x.push_back(s.t / T);
      cm.y.push_back(s.command[0]);
    }
  }
  plot.series = {th};
  if (dofs == DofSet::six_dof) plot.series.push_back(ph);
  if (!cm.x.empty()) plot.series.push_back(cm);
  std::string why;
  const auto svg = render_svg(plot, why);
  if (!svg) j["figure_notice"] = why;
  std::vector<std::pair<std::string, std::string>> out = {{dir + "/trajectory.csv", csv},
                                                          {dir + "/run.json", j.dump(2) + "\n"}};
  if (svg) out.emplace_back(dir + "/response.svg", *svg);
  write_files_atomic(out);  // the set as one: all or none
  if (!o.quiet) {
    if (!r.completed) fmt::print("  stopped: {}\n", r.stop_reason);
    fmt::print("{}", growth_lines(growth, "orbit"));
    fmt::print("  {} steps, {} load evaluations, simulation {:.3f} s\n", r.steps, r.rhs_evaluations, r.wall_time_s);
    fmt::print("wrote {}/trajectory.csv, run.json{} in {:.2f} s\n", dir, svg ? ", response.svg" : "", seconds_since(t0));
  }
  return 0;
}

}  // namespace

int run_fly(const FlightCommandOptions& o) {
  if (ns::Decomposition::launched_processes() == 1) return fly(o, nullptr);
  // Under mpiexec: MPI first, so that bad input is printed once (by rank 0) and ends every rank alike.
  std::shared_ptr<const ns::Decomposition> ranks;
  try {
    ranks = ns::Decomposition::launched();
  } catch (const std::runtime_error& e) {  // several processes, but built without MPI
    throw InputError("mpiexec", "-n", e.what(), "one process (its threads: [aero.cfd] threads or OMP_NUM_THREADS)");
  }
  return run_over_ranks(*ranks, "flapstab fly", [&] { return fly(o, ranks); });
}

namespace {

struct CheckPoint {
  double gain = 0, latency = 0;
  double lti_abscissa = 0;         // 1/s
  double floquet_radius = 0;       // spectral radius of the delayed periodic loop
  double simulated_growth = 0;     // per wingbeat
  bool completed = true;
  bool inside = false;             // chosen inside the averaged model's stable region
  // Whether the flight gave a growth or diverged ([control.map] check_wingbeats long enough to fit one).
  bool simulated() const { return !std::isnan(simulated_growth); }
  bool agree() const {
    const bool grows = simulated_growth >= 0;
    return simulated() && (lti_abscissa >= 0) == grows && (floquet_radius >= 1) == grows;
  }
};

// Simulated growth per wingbeat of a 0.5 deg pitch perturbation of the periodic orbit under the controller.
CheckPoint check_point(const HoverModel& h, const FlightDynamics& dyn, const PitchControllerSettings& base, MapGain which,
                       double trim, double gain, double latency, const LinearPlant& plant, const PeriodicPlant& pp,
                       double wingbeats) {
  CheckPoint p;
  p.gain = gain;
  p.latency = latency;
  const ControllerSpec cs = controller_at(base, which, gain, latency, trim);
  p.lti_abscissa = rightmost_roots(closed_loop(plant, cs)).spectral_abscissa();
  p.floquet_radius = delayed_floquet(closed_loop(pp, cs)).spectral_radius();
  BodyStateVector x0 = h.cyclic.initial_state;
  x0(10) += 0.5 * deg;
  FlightOptions fo;
  fo.wingbeats = wingbeats;
  fo.samples_per_wingbeat = 40;
  const ReferenceOrbit ref = reference_orbit(h.orbit, h.cyclic.period);
  const FlightResult r = simulate_flight(dyn, cs, x0, ref, h.derivatives.table.reference, fo);
  p.completed = r.completed;
  p.simulated_growth = r.completed
                           ? wingbeat_growth(r, ref, h.derivatives.table.reference, h.cyclic.period, {3, 5, 7, 10}).per_wingbeat
                           : INFINITY;
  return p;
}

// A check point's simulated growth: a number, "diverged" (the flight left the attitude envelope) or "not fitted"
// ([control.map] check_wingbeats leaves fewer than two wingbeats with a deviation to fit).
json simulated_growth_json(double g) {
  return std::isfinite(g) ? json(g) : std::isinf(g) ? json("diverged") : json("not fitted");
}
// The same for the terminal: the growth per wingbeat with its sign, or the word.
std::string simulated_growth_text(double g) {
  return std::isfinite(g) ? fmt::format("{:+.4f}", g) : std::isinf(g) ? "diverged" : "not fitted";
}

json latency_json(double tau, double T) {
  if (std::isnan(tau)) return nullptr;
  if (std::isinf(tau)) return "stable over the whole map";
  return {{"s", tau}, {"ms", tau * 1e3}, {"wingbeats", tau / T}};
}

}  // namespace

int run_control_map(const FlightCommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case_for(o.case_path, "control-map");
  require_quasi_steady(c, "control-map");
  const std::string dir = output_dir(c, o.output_dir);
  if (c.control.type != "pitch")
    throw InputError(c.path, "control.type", "control-map maps the pitch controller's (gain, latency) plane",
                     "type = \"pitch\" with a [control.pitch] table");
  const auto model = make_aero_model(c);
  const std::vector<TrimParameterSpec> actuators = controller_actuators(c);
  const HoverModel h = hover_model(c, *model, actuators);
  const double T = h.cyclic.period;
  const double trim = parameter_value(h.cyclic.kinematics, c.control.actuator, c.path);
  const PitchControllerSettings base = pitch_controller_settings(c.control);
  const MapGain which = c.control.map_gain == "rate" ? MapGain::rate : MapGain::pitch;
  const LinearPlant& plant = h.longitudinal;
  const double latency_max = c.control.map_latency_max_s > 0 ? c.control.map_latency_max_s : 3 * T;
  if (!o.quiet)
    fmt::print("{}: pitch control map of '{}' on {}: {} x {} points, {} gain in [{}, {}], latency 0 to {:.1f} ms "
               "({:.2f} wingbeats); hover models in {:.2f} s\n",
               c.path, c.insect.name, c.control.actuator, c.control.map_gains, c.control.map_latencies,
               c.control.map_gain, c.control.map_gain_min, c.control.map_gain_max, latency_max * 1e3,
               latency_max / T, h.wall_time_s);
  std::vector<double> gains, latencies;
  for (int i = 0; i < c.control.map_gains; ++i)
    gains.push_back(c.control.map_gain_min + (c.control.map_gain_max - c.control.map_gain_min) * i / (c.control.map_gains - 1));
  for (int j = 0; j < c.control.map_latencies; ++j) latencies.push_back(latency_max * j / (c.control.map_latencies - 1));
  const DelaySystemBuilder build = [&](double g, double tau) {
    return closed_loop(plant, controller_at(base, which, g, tau, trim), c.path, "control.pitch");
  };
  const auto tm = std::chrono::steady_clock::now();
  const StabilityMap map = stability_map(build, gains, latencies);
  const double map_s = seconds_since(tm);
  std::vector<CriticalLatency> boundary;
  for (double g : gains) boundary.push_back(critical_latency(build, g, latency_max));
  const CriticalLatency best = best_gain(build, c.control.map_gain_min, c.control.map_gain_max, latency_max);
  // Stable latency windows per gain: runs of negative abscissa on the grid, their ends refined by bisection on the
  // spectral abscissa (a loop unstable without delay can be stabilised by a delay within a window).
  struct Window {
    double from = 0, to = 0;
  };
  std::vector<std::vector<Window>> windows(gains.size());
  double widest_latency = -1, widest_gain = std::nan("");
  auto refine = [&](double g, double a, double b) {  // abscissa changes sign between a and b
    const bool a_stable = rightmost_roots(build(g, a)).spectral_abscissa() < 0;
    for (int it = 0; it < 30 && b - a > 1e-6 * latency_max; ++it) {
      const double m = 0.5 * (a + b);
      ((rightmost_roots(build(g, m)).spectral_abscissa() < 0) == a_stable ? a : b) = m;
    }
    return 0.5 * (a + b);
  };
  for (std::size_t i = 0; i < gains.size(); ++i) {
    for (std::size_t k = 0; k < latencies.size(); ++k) {
      if (!(map.abscissa(Eigen::Index(i), Eigen::Index(k)) < 0)) continue;
      if (k > 0 && map.abscissa(Eigen::Index(i), Eigen::Index(k - 1)) < 0) continue;  // not the start of a run
      std::size_t e = k;
      while (e + 1 < latencies.size() && map.abscissa(Eigen::Index(i), Eigen::Index(e + 1)) < 0) ++e;
      Window w;
      w.from = k == 0 ? 0.0 : refine(gains[i], latencies[k - 1], latencies[k]);
      w.to = e + 1 == latencies.size() ? INFINITY : refine(gains[i], latencies[e], latencies[e + 1]);
      windows[i].push_back(w);
      if (w.to > widest_latency) widest_latency = w.to, widest_gain = gains[i];
    }
  }
  const double boundary_s = seconds_since(tm) - map_s;
  // The time-periodic loop at the best gain: its own critical latency (bisection on the spectral radius).
  const FlightDynamics dyn(*model, c.insect, h.cyclic.kinematics, pitch_controller(base, trim).actuators,
                           DofSet::longitudinal);
  const PeriodicPlant pp = periodic_plant(dyn, h.phase, {"u", "w", "q", "theta"});
  auto radius = [&](double g, double tau) {
    return delayed_floquet(closed_loop(pp, controller_at(base, which, g, tau, trim))).spectral_radius();
  };
  double periodic_critical = std::nan("");
  if (std::isfinite(best.gain) && radius(best.gain, 0) < 1) {
    double lo = 0, hi = std::nan("");
    for (int k = 1; k <= 12; ++k) {
      const double tau = latency_max * k / 12;
      if (radius(best.gain, tau) >= 1) {
        hi = tau;
        break;
      }
      lo = tau;
    }
    if (std::isnan(hi)) periodic_critical = INFINITY;
    else {
      for (int it = 0; it < 10; ++it) {
        const double mid = 0.5 * (lo + hi);
        (radius(best.gain, mid) < 1 ? lo : hi) = mid;
      }
      periodic_critical = 0.5 * (lo + hi);
    }
  }
  // The periodic loop on a coarser grid over the same ranges: spectral radius of the delayed monodromy.
  std::vector<double> pgains, plats;
  Eigen::MatrixXd pradius;
  const auto tp = std::chrono::steady_clock::now();
  if (c.control.map_periodic_gains > 0) {
    for (int i = 0; i < c.control.map_periodic_gains; ++i)
      pgains.push_back(c.control.map_gain_min +
                       (c.control.map_gain_max - c.control.map_gain_min) * i / (c.control.map_periodic_gains - 1));
    for (int k = 0; k < c.control.map_periodic_latencies; ++k)
      plats.push_back(latency_max * k / (c.control.map_periodic_latencies - 1));
    pradius.resize(Eigen::Index(pgains.size()), Eigen::Index(plats.size()));
    for (std::size_t i = 0; i < pgains.size(); ++i)
      for (std::size_t k = 0; k < plats.size(); ++k) pradius(Eigen::Index(i), Eigen::Index(k)) = radius(pgains[i], plats[k]);
  }
  const double periodic_map_s = seconds_since(tp);
  // Check points: at the best gain, three latencies inside the averaged stable range and three beyond it.
  std::vector<CheckPoint> checks;
  if (std::isfinite(best.latency) && c.control.map_check_points > 0) {
    const int n = c.control.map_check_points;
    for (int k = 0; k < n; ++k) {
      const double inside = best.latency * (0.2 + 0.6 * k / std::max(1, n - 1));
      const double outside = std::min(latency_max, best.latency * (1.25 + 0.5 * k / std::max(1, n - 1)));
      CheckPoint a = check_point(h, dyn, base, which, trim, best.gain, inside, plant, pp, c.control.map_check_wingbeats);
      a.inside = true;
      checks.push_back(a);
      CheckPoint b = check_point(h, dyn, base, which, trim, best.gain, outside, plant, pp, c.control.map_check_wingbeats);
      checks.push_back(b);
    }
  }
  // The case's own controller.
  const ControllerSpec own = pitch_controller(base, trim);
  const DelayRoots own_roots = rightmost_roots(closed_loop(plant, own, c.path, "control.pitch"));
  const DelayFloquet own_floquet = delayed_floquet(closed_loop(pp, own, c.path, "control.pitch"));
  const NeutralAxis na = neutral_axis(h.derivatives.table);
  const Eigen::VectorXcd open_lti = Eigen::EigenSolver<Eigen::MatrixXd>(plant.A).eigenvalues();
  double open_abscissa = -INFINITY;
  for (Eigen::Index i = 0; i < open_lti.size(); ++i) open_abscissa = std::max(open_abscissa, open_lti(i).real());

  json j = metadata_json(c, "control-map");
  const std::string gain_unit = which == MapGain::pitch ? "deg of actuator per deg of pitch" : "deg of actuator per deg/s of pitch rate (s)";
  j["map"] = {{"actuator", c.control.actuator},
              {"gain_axis", c.control.map_gain},
              {"gain_unit", gain_unit},
              {"other_gain", which == MapGain::pitch ? base.rate_gain_s : base.pitch_gain},
              {"latency_applies_to", "both the pitch-angle and the pitch-rate signals"},
              {"law", "delta p = -(pitch_gain theta_deg(t - latency) + rate_gain_s q_deg_s(t - latency)), deviations from the periodic orbit"},
              {"system", "averaged longitudinal [u, w, q, theta] with the control derivatives, SI, delay-exact"},
              {"gains", gains},
              {"latencies_s", latencies},
              {"spectral_abscissa_per_s", matrix_json(map.abscissa)},
              {"collocation_intervals", map.nodes},
              {"discretisation_verified", map.converged},
              {"map_time_s", map_s},
              {"boundary_time_s", boundary_s}};
  json bj = json::array();
  for (std::size_t i = 0; i < boundary.size(); ++i) {
    const auto& b = boundary[i];
    json wj = json::array();
    for (const auto& w : windows[i]) wj.push_back({{"from", latency_json(w.from, T)}, {"to", latency_json(w.to, T)}});
    bj.push_back({{"gain", b.gain}, {"stable_without_delay", b.stable_without_delay}, {"critical_latency", latency_json(b.latency, T)},
                  {"crossing_frequency_rad_s", std::isfinite(b.crossing_frequency) ? json(b.crossing_frequency) : json(nullptr)},
                  {"stable_latency_windows", wj}});
  }
  j["boundary"] = bj;
  j["boundary_note"] = "critical_latency: the first loss of stability from latency 0 (for gains stable without delay); "
                       "stable_latency_windows: every latency interval of the map where the loop is stable, ends refined "
                       "by bisection (delay can stabilise a loop that is unstable without it)";
  j["largest_stabilising_latency"] = {{"gain", std::isfinite(widest_gain) ? json(widest_gain) : json(nullptr)},
                                      {"latency", widest_latency > 0 ? latency_json(widest_latency, T) : json(nullptr)},
                                      {"note", "the upper end of the highest stable window over the map's gains (grid in gain)"}};
  if (pradius.size() > 0) {
    json rows = json::array();
    int agree = 0, total = 0;
    for (Eigen::Index i = 0; i < pradius.rows(); ++i) {
      json row = json::array();
      for (Eigen::Index k = 0; k < pradius.cols(); ++k) {
        row.push_back(std::log(pradius(i, k)));
        const double a = rightmost_roots(build(pgains[std::size_t(i)], plats[std::size_t(k)])).spectral_abscissa();
        agree += (a < 0) == (pradius(i, k) < 1);
        ++total;
      }
      rows.push_back(row);
    }
    j["periodic_map"] = {{"system", "time-periodic longitudinal loop along the cyclic-trim orbit: A(t) phase-resolved, "
                                    "B(t) by differences of the free system in the actuator; semi-discretised monodromy"},
                         {"gains", pgains},
                         {"latencies_s", plats},
                         {"growth_per_wingbeat", rows},
                         {"growth_note", "log of the largest multiplier modulus per wingbeat (< 0 stable)"},
                         {"points_where_averaged_and_periodic_agree", agree},
                         {"points", total},
                         {"time_s", periodic_map_s}};
  }
  j["best_gain"] = {{"gain", best.gain}, {"critical_latency_averaged", latency_json(best.latency, T)},
                    {"critical_latency_periodic", latency_json(periodic_critical, T)},
                    {"crossing_frequency_rad_s", std::isfinite(best.crossing_frequency) ? json(best.crossing_frequency) : json(nullptr)}};
  json cj = json::array();
  int agreed = 0;
  for (const auto& p : checks) {
    agreed += p.agree();
    cj.push_back({{"gain", p.gain}, {"latency", latency_json(p.latency, T)}, {"chosen", p.inside ? "inside" : "outside"},
                  {"lti_spectral_abscissa_per_s", p.lti_abscissa}, {"lti_growth_per_wingbeat", p.lti_abscissa * T},
                  {"floquet_spectral_radius", p.floquet_radius}, {"floquet_growth_per_wingbeat", std::log(p.floquet_radius)},
                  {"simulated_growth_per_wingbeat", simulated_growth_json(p.simulated_growth)},
                  {"simulation_completed", p.completed},
                  {"all_three_agree", p.simulated() ? json(p.agree()) : json(nullptr)}});
  }
  j["check_points"] = cj;
  j["check_points_note"] = fmt::format("nonlinear free flight (longitudinal degrees of freedom) from the periodic orbit "
                                       "with 0.5 deg of pitch, {} wingbeats; growth fitted over the second half",
                                       c.control.map_check_wingbeats);
  j["case_controller"] = {{"description", own.description},
                          {"lti_spectral_abscissa_per_s", own_roots.spectral_abscissa()},
                          {"floquet_spectral_radius", own_floquet.spectral_radius()},
                          {"stable_lti", own_roots.spectral_abscissa() < 0},
                          {"stable_periodic", own_floquet.spectral_radius() < 1}};
  j["open_loop"] = {{"lti_spectral_abscissa_per_s", open_abscissa}, {"lti_growth_per_wingbeat", open_abscissa * T}};
  j["neutral_axis"] = {{"z_at_centre_of_mass_m", na.z_at_com}, {"z_over_chord", na.z_at_com / h.derivatives.table.reference.c},
                       {"slope_dz_dx", na.slope}, {"centre_of_mass_below_axis_m", na.com_below_axis_m},
                       {"definition", "points P about which dM_P/du = M_u - (z_P X_u - x_P Z_u) = 0 (stability axes, z down)"}};
  j["control_derivatives"] = json::array();
  for (std::size_t k = 0; k < h.control.columns.size(); ++k) {
    const auto& col = h.control.columns[k];
    j["control_derivatives"].push_back({{"parameter", col.parameter}, {"unit", col.unit},
                                        {"nd", {{"X", col.nd(0)}, {"Y", col.nd(1)}, {"Z", col.nd(2)}, {"L", col.nd(3)}, {"M", col.nd(4)}, {"N", col.nd(5)}}},
                                        {"gravity_moment_M_N_m_per_unit", h.control.gravity_si(4, Eigen::Index(k))}});
  }
  j["period_s"] = T;
  std::vector<ComSweepPoint> sweep;
  if (o.com_sweep) {
    const double cbar = h.derivatives.table.reference.c;
    std::vector<double> dz;
    for (int k = -4; k <= 4; ++k) dz.push_back(0.25 * k * cbar);
    sweep = com_height_sweep(c, *model, dz, c.control.map_check_wingbeats);
    json sj = json::array();
    for (const auto& p : sweep)
      sj.push_back({{"dz_m", p.dz}, {"dz_over_chord", p.dz / cbar}, {"com_below_neutral_axis_m", p.com_below_axis_m},
                    {"lti_growth_per_wingbeat", p.lti_growth}, {"lti_mode_oscillatory", p.lti_oscillatory},
                    {"floquet_growth_per_wingbeat", p.floquet_growth},
                    {"simulated_growth_per_wingbeat", simulated_growth_json(p.simulated_growth)}});
    j["com_sweep"] = {{"note", "centre of mass moved by dz (+down) relative to the wing hinges, re-trimmed, open loop; "
                               "largest longitudinal growth per wingbeat"},
                      {"points", sj}};
  }
  j["wall_time_s"] = seconds_since(t0);

  std::string csv = "gain,latency_s,latency_wingbeats,spectral_abscissa_per_s,growth_per_wingbeat,stable\n";
  for (std::size_t i = 0; i < gains.size(); ++i)
    for (std::size_t k = 0; k < latencies.size(); ++k) {
      const double a = map.abscissa(Eigen::Index(i), Eigen::Index(k));
      csv += fmt::format("{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{}\n", gains[i], latencies[k], latencies[k] / T, a, a * T, a < 0 ? 1 : 0);
    }
  MapPlot mp;
  mp.title = c.insect.name + ": delayed pitch feedback, averaged model";
  mp.xlabel = c.control.map_gain + " gain (" + gain_unit + ")";
  mp.ylabel = "latency (wingbeats)";
  mp.cblabel = "spectral abscissa per wingbeat";
  mp.x = gains;
  for (double tau : latencies) mp.y.push_back(tau / T);
  mp.z.resize(gains.size());
  for (std::size_t i = 0; i < gains.size(); ++i)
    for (std::size_t k = 0; k < latencies.size(); ++k) mp.z[i].push_back(map.abscissa(Eigen::Index(i), Eigen::Index(k)) * T);
  Series bl{"critical latency (averaged)", {}, {}};
  for (const auto& b : boundary) {
    bl.x.push_back(b.gain);
    bl.y.push_back(std::isfinite(b.latency) ? b.latency / T : std::nan(""));
  }
  Series edges{"stability boundary (window ends)", {}, {}};
  for (std::size_t i = 0; i < gains.size(); ++i)
    for (const auto& w : windows[i])
      for (double e : {w.from, w.to})
        if (e > 0 && std::isfinite(e)) {
          edges.x.push_back(gains[i]);
          edges.y.push_back(e / T);
        }
  mp.lines = {bl};
  mp.dots = {edges};
  Series sp{"simulated: decays", {}, {}}, su{"simulated: grows", {}, {}};
  for (const auto& p : checks) {
    if (!p.simulated()) continue;  // too short a flight for a growth: neither
    Series& s = p.simulated_growth < 0 ? sp : su;
    s.x.push_back(p.gain);
    s.y.push_back(p.latency / T);
  }
  mp.points = {sp, su};
  std::string why;
  const auto svg = render_svg(mp, why);
  if (!svg) j["figure_notice"] = why;
  std::optional<std::string> psvg;
  if (pradius.size() > 0 && svg) {
    MapPlot pm = mp;
    pm.title = c.insect.name + ": delayed pitch feedback, periodic (Floquet) model";
    pm.cblabel = "log of the largest multiplier modulus per wingbeat";
    pm.x = pgains;
    pm.y.clear();
    for (double tau : plats) pm.y.push_back(tau / T);
    pm.z.assign(pgains.size(), {});
    for (std::size_t i = 0; i < pgains.size(); ++i)
      for (std::size_t k = 0; k < plats.size(); ++k) pm.z[i].push_back(std::log(pradius(Eigen::Index(i), Eigen::Index(k))));
    pm.lines.front().title = "critical latency (averaged, for comparison)";
    pm.dots.front().title = "averaged stability boundary";
    psvg = render_svg(pm, why);
  }
  std::vector<std::pair<std::string, std::string>> out = {{dir + "/control_map.json", j.dump(2) + "\n"},
                                                          {dir + "/control_map.csv", csv}};
  if (psvg) out.emplace_back(dir + "/control_map_periodic.svg", *psvg);
  if (svg) out.emplace_back(dir + "/control_map.svg", *svg);
  write_files_atomic(out);  // the set as one: all or none
  if (!o.quiet) {
    fmt::print("  open loop (averaged): growth {:+.4f} per wingbeat; neutral axis {:.2f} mm above the CoM ({:.2f} c)\n",
               open_abscissa * T, -na.z_at_com * 1e3, -na.z_at_com / h.derivatives.table.reference.c);
    fmt::print("  map {:.2f} s ({} collocation intervals{}), boundary and best gain {:.2f} s\n", map_s, map.nodes,
               map.converged ? ", verified" : "", boundary_s);
    if (j.contains("periodic_map"))
      fmt::print("  periodic map {} x {} in {:.2f} s: averaged and periodic agree on stability at {} of {} points\n",
                 pgains.size(), plats.size(), periodic_map_s, j["periodic_map"]["points_where_averaged_and_periodic_agree"].get<int>(),
                 j["periodic_map"]["points"].get<int>());
    if (std::isfinite(best.gain))
      fmt::print("  best {} gain {:.4g}: critical latency {} (averaged), {} (periodic)\n", c.control.map_gain, best.gain,
                 std::isfinite(best.latency) ? fmt::format("{:.2f} ms = {:.3f} wingbeats", best.latency * 1e3, best.latency / T) : "none",
                 std::isfinite(periodic_critical) ? fmt::format("{:.2f} ms = {:.3f} wingbeats", periodic_critical * 1e3, periodic_critical / T)
                                                  : (std::isinf(periodic_critical) ? "beyond the map" : "none"));
    else
      fmt::print("  no gain in [{}, {}] stabilises the averaged hover at zero latency\n", c.control.map_gain_min, c.control.map_gain_max);
    if (widest_latency > 0)
      fmt::print("  largest latency any mapped gain tolerates: {:.2f} ms = {:.3f} wingbeats (gain {:.4g}, inside a stable "
                 "window that does not reach latency 0 when the gain is below the zero-latency range)\n",
                 widest_latency * 1e3, widest_latency / T, widest_gain);
    for (const auto& p : checks)
      fmt::print("  check {:7} gain {:.4g}, latency {:6.2f} ms: LTI {:+.4f}/wb, periodic {:+.4f}/wb, simulated {}{}\n",
                 p.inside ? "inside" : "outside", p.gain, p.latency * 1e3, p.lti_abscissa * T, std::log(p.floquet_radius),
                 simulated_growth_text(p.simulated_growth) + (std::isfinite(p.simulated_growth) ? "/wb" : ""),
                 p.agree() || !p.simulated() ? "" : "  (models disagree)");
    const auto simulated =
        std::count_if(checks.begin(), checks.end(), [](const CheckPoint& p) { return p.simulated(); });
    if (simulated > 0)
      fmt::print("  {} of {} check points: averaged, periodic and simulated agree on stability\n", agreed, simulated);
    if (simulated < std::ptrdiff_t(checks.size()))
      fmt::print("  {} check points not compared: their flights are too short for a growth ([control.map] "
                 "check_wingbeats = {:g}; the fit needs two wingbeats in the second half)\n",
                 std::ptrdiff_t(checks.size()) - simulated, c.control.map_check_wingbeats);
    fmt::print("  case controller ({}): averaged {}, periodic {}\n", own.description,
               own_roots.spectral_abscissa() < 0 ? "stable" : "unstable", own_floquet.spectral_radius() < 1 ? "stable" : "unstable");
    if (!sweep.empty()) {
      fmt::print("  centre of mass moved below the wing hinges (open loop, growth per wingbeat):\n");
      fmt::print("  {:>10} {:>22} {:>10} {:>10} {:>10}\n", "dz (c)", "CoM below axis (mm)", "averaged", "Floquet", "simulated");
      for (const auto& p : sweep)
        fmt::print("  {:>10.2f} {:>22.2f} {:>+10.4f} {:>+10.4f} {:>10}\n", p.dz / h.derivatives.table.reference.c,
                   p.com_below_axis_m * 1e3, p.lti_growth, p.floquet_growth, simulated_growth_text(p.simulated_growth));
    }
    fmt::print("wrote {}/control_map.json, control_map.csv{}{} in {:.2f} s\n", dir, svg ? ", control_map.svg" : "",
               psvg ? ", control_map_periodic.svg" : "", seconds_since(t0));
  }
  return 0;
}

}  // namespace flapstab
