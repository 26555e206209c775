// flapstab subcommands: trim-hover, derivatives, stability and analyze.
#include "apps/commands.hpp"
#include "apps/over_ranks.hpp"
#include "cfd/navier_stokes/decomposition.hpp"

#include <chrono>
#include <iostream>
#include <optional>
#include <fmt/format.h>

#include "apps/cfd_study.hpp"
#include "apps/floquet_command.hpp"
#include "apps/report.hpp"
#include "apps/revolving.hpp"
#include "apps/results_json.hpp"
#include "apps/stability_json.hpp"
#include "stability/analysis.hpp"
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "flight/control_derivatives.hpp"
#include "trim/refine.hpp"
#include "trim/trim.hpp"

namespace flapstab {

namespace {

// Whether this process speaks for its group of ranks (logs, prints and writes the command's files): rank 0 of a
// --ranks-per-flow group, or a process alone.
bool speaks(const CommandOptions& o) { return !o.flow_ranks || o.flow_ranks->rank() == 0; }

// The log of the command's CFD model: stderr unless --quiet, on the process that speaks.
std::ostream* cfd_log(const CommandOptions& o) { return o.quiet || !speaks(o) ? nullptr : &std::cerr; }

// The CFD run cache of a command's output directory ("" without one).
std::string cfd_cache(const CommandOptions& o, const Case& c) {
  const std::string dir = o.output_dir.empty() ? c.output_directory : o.output_dir;
  return dir.empty() ? std::string() : dir + "/cfd_runs";
}

TrimResult trimmed(const Case& c, const AeroModel& model) {
  TrimResult t = trim_hover(c, model);
  if (!t.converged) {
    const auto active = t.active_bounds();
    std::string held;
    for (const auto& a : active) held += (held.empty() ? "" : "; ") + a;
    throw SolveError(fmt::format(
        "{}: trim did not converge ({}); residuals: force {:.3e} of weight, moment {:.3e} of weight x wing "
        "length (tolerance {:.1e}). {}",
        c.path, t.message, t.relative_force_residual, t.relative_moment_residual, c.trim.tolerance,
        active.empty() ? std::string("No parameter ends on a bound: free other parameters ([[trim.parameter]]) or "
                                     "raise trim.max_iterations.")
                       : "Held by " + held + ": widen that bound or free other parameters ([[trim.parameter]])."));
  }
  return t;
}

// The trim, or with --no-trim the case's kinematics evaluated as they are (the quasi-steady model only: the CFD
// study trims on the CFD loads as part of its runs).
TrimResult trim_or_evaluate(const CommandOptions& o, const Case& c, const AeroModel& model) {
  return o.no_trim ? evaluate_at_case_kinematics(c, model) : trimmed(c, model);
}

void refuse_no_trim_with_cfd(const CommandOptions& o, const Case& c) {
  if (o.no_trim && c.aero.model == "cfd")
    throw InputError(c.path, "aero.model", "--no-trim is not available with the CFD model (its study trims on the CFD "
                                           "loads)", "model = \"quasi-steady\" for --no-trim");
}

void print_trim(const Case& c, const TrimResult& t, double seconds) {
  if (!t.solved) {
    fmt::print("{}: '{}' NOT TRIMMED (--no-trim): the case's kinematics as given, {:.3f} s\n", c.path, c.insect.name,
               seconds);
    fmt::print("  residual: force {:.3e} x weight (X {:.4g}, Y {:.4g}, Z {:.4g} N), moment {:.3e} x weight x R "
               "(L {:.4g}, M {:.4g}, N {:.4g} N m); mean aerodynamic power {:.4g} W\n",
               t.relative_force_residual, t.force_residual.x(), t.force_residual.y(), t.force_residual.z(),
               t.relative_moment_residual, t.moment_residual.x(), t.moment_residual.y(), t.moment_residual.z(),
               t.mean_power);
    return;
  }
  fmt::print("{}: hover trim of '{}' with {} ({}), {:.3f} s, {} iterations, {} model runs\n", c.path, c.insect.name,
             t.solver, t.objective, seconds, t.iterations, t.model_runs);
  for (const auto& p : t.parameters)
    fmt::print("  {:<24} {:>12.6f} {:<3}  (initial {:.6g}, bounds [{:g}, {:g}])\n", p.label, p.value, p.unit, p.initial,
               p.lower, p.upper);
  fmt::print("  residual: force {:.2e} x weight, moment {:.2e} x weight x R; mean aerodynamic power {:.4g} W\n",
             t.relative_force_residual, t.relative_moment_residual, t.mean_power);
}

// Stability derivatives and, for every parameter the case can actuate, the control derivatives.
DerivativeResult derivatives_with_control(const Case& c, const AeroModel& model, const Kinematics& kin) {
  DerivativeResult d = cycle_averaged_derivatives(model, c.insect, kin, c.fluid, c.derivatives.relative_step, {},
                                                  derivative_columns(c.derivatives.columns),
                                                  c.derivatives.relative_rate_step);
  const ControlDerivativeResult cd = control_derivatives(model, c.insect, kin, actuated_parameters(c), d.table.reference);
  d.table.control = cd.columns;
  d.model_runs += cd.model_runs;
  return d;
}

}  // namespace

Case load_case_for(const std::string& path, const std::string& command) {
  Case c = load_case(path);
  if (c.body_motion.present)
    throw InputError(path, "body_motion",
                     "the translation-only model (prescribed attitude) is solved by flapstab floquet only, not by "
                     "flapstab " + command,
                     "flapstab floquet for a case with [body_motion], or the case without it");
  return c;
}

int run_trim_hover(const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case_for(o.case_path, "trim-hover");
  const auto model = make_aero_model(c);
  TrimResult t;
  if (c.aero.model == "cfd") {  // the quasi-steady trim, refined on the CFD cycle means (trim/refine.hpp)
    Case qc = c;
    qc.aero.model = "quasi-steady";
    const auto qs = make_aero_model(qc);
    const TrimResult start = trimmed(qc, *qs);
    ns::CfdModel cfd(c, cfd_log(o), cfd_cache(o, c));
    cfd.run_over(o.flow_ranks);
    cfd.plan_for(trim_extreme_kinematics(c, start));
    t = refine_trim(c, cfd, *qs, start, RefineSettings{c.aero.cfd.trim_tolerance, c.aero.cfd.trim_iterations},
                    cfd_log(o));
  } else {
    t = trimmed(c, *model);
  }
  if (!speaks(o)) return 0;
  const double secs = seconds_since(t0);
  nlohmann::json j = metadata_json(c, "trim-hover");
  j["trim"] = trim_json(t);
  j["wall_time_s"] = secs;
  const std::string text = j.dump(2) + "\n";
  std::vector<std::pair<std::string, std::string>> out;
  if (!o.json_path.empty()) out.emplace_back(o.json_path, text);
  if (!o.output_dir.empty()) out.emplace_back(o.output_dir + "/trim.json", text);
  write_files_atomic(out);
  if (!o.quiet) print_trim(c, t, secs);
  return 0;
}

int run_derivatives(const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case_for(o.case_path, "derivatives");
  refuse_no_trim_with_cfd(o, c);
  std::optional<CfdStudy> cfd;
  TrimResult t;
  DerivativeResult d;
  if (c.aero.model == "cfd") {
    cfd = cfd_study(c, cfd_cache(o, c), cfd_log(o), o.flow_ranks);
    t = cfd->trim;
    d = cfd->derivatives;
  } else {
    const auto model = make_aero_model(c);
    t = trim_or_evaluate(o, c, *model);
    d = derivatives_with_control(c, *model, t.kinematics);
  }
  if (!speaks(o)) return 0;
  const double secs = seconds_since(t0);
  nlohmann::json j = metadata_json(c, "derivatives");
  j["trim"] = trim_json(t);
  j["derivatives"] = derivatives_json(d);
  if (cfd) j["cfd"] = cfd_study_json(*cfd);
  j["wall_time_s"] = secs;
  const std::string text = j.dump(2) + "\n";
  DerivativeTable table = d.table;
  table.source = c.path + " (" + d.table.source + ")";
  const std::string toml = derivative_table_toml(table);
  std::vector<std::pair<std::string, std::string>> out;
  if (!o.json_path.empty()) out.emplace_back(o.json_path, text);
  if (!o.output_dir.empty()) {
    out.emplace_back(o.output_dir + "/derivatives.json", text);
    out.emplace_back(o.output_dir + "/derivatives.toml", toml);
  }
  write_files_atomic(out);
  if (!o.quiet) {
    print_trim(c, t, secs);
    fmt::print("cycle-averaged derivatives (non-dimensional, hover stability axes; rows X Y Z L M N, "
               "columns u v w p q r; - : not computed, [derivatives] columns):\n");
    // The columns of a plane the table does not hold (longitudinal: u w q; lateral: v p r) are not computed.
    auto held = [&](int k) { return k % 2 == 0 ? d.table.has_longitudinal : d.table.has_lateral; };
    for (int i = 0; i < 6; ++i) {
      fmt::print("  {}", "XYZLMN"[i]);
      for (int k = 0; k < 6; ++k) {
        fmt::print(" {:>11}", held(k) ? fmt::format("{:.4e}", d.table.nd(i, k)) : std::string("-"));
      }
      fmt::print("\n");
    }
    if (cfd) fmt::print("\n{}", cfd_study_markdown(*cfd));
  }
  return 0;
}

namespace {

StabilityReport stability_of(const DerivativeTable& table, const std::string& model) {
  StabilityRequest req;
  req.six_dof = model == "6dof";
  StabilityReport rep = analyse_stability(table, req);
  if (model == "longitudinal") rep.lateral.reset();
  if (model == "lateral") rep.longitudinal.reset();
  return rep;
}

// A single analysis (--model longitudinal|lateral) is written as that analysis' object; 6dof as the
// report keyed longitudinal, lateral, 6dof.
nlohmann::json stability_json(const StabilityReport& rep, const std::string& model) {
  nlohmann::json j = to_json(rep);
  if (model == "longitudinal" && rep.longitudinal) j["analysis"] = to_json(*rep.longitudinal);
  if (model == "lateral" && rep.lateral) j["analysis"] = to_json(*rep.lateral);
  if (model != "6dof") {
    nlohmann::json single = j["analysis"];
    if (single.is_null())
      throw SolveError("the derivative table has no " + model + " derivatives: nothing to analyse");
    for (const char* k : {"conventions", "units", "source", "reference", "nondimensional_parameters", "notices"})
      if (j.contains(k)) single[k] = j[k];
    return single;
  }
  return j;
}

}  // namespace

int run_stability(const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (o.model != "longitudinal" && o.model != "lateral" && o.model != "6dof")
    throw InputError("", "--model", "unknown model \"" + o.model + "\"", "longitudinal, lateral or 6dof");
  nlohmann::json j;
  DerivativeTable table;
  if (!o.derivatives_path.empty()) {
    if (o.no_trim)
      throw InputError(o.derivatives_path, "--no-trim", "given with --derivatives (a table is not trimmed)",
                       "--no-trim with a case file only");
    table = read_derivative_table(o.derivatives_path);
    const bool lon = o.model != "lateral", lat = o.model != "longitudinal";
    if ((!lon || !table.has_longitudinal) && (!lat || !table.has_lateral))
      throw InputError(o.derivatives_path, "derivatives",
                       "holds no derivative section the '" + o.model + "' analysis can use",
                       o.model == "lateral" ? "[derivatives.lateral]"
                                            : (o.model == "longitudinal" ? "[derivatives.longitudinal]"
                                                                         : "[derivatives.longitudinal] and/or [derivatives.lateral]"));
    j = {{"program", "flapstab"}, {"version", FLAPSTAB_VERSION}, {"command", "stability"},
         {"derivative_table", o.derivatives_path}, {"derivative_table_fnv1a64", file_hash(o.derivatives_path)}};
  } else {
    const Case c = load_case_for(o.case_path, "stability");
    refuse_no_trim_with_cfd(o, c);
    j = metadata_json(c, "stability");
    if (c.aero.model == "cfd") {
      const CfdStudy cfd = cfd_study(c, cfd_cache(o, c), cfd_log(o), o.flow_ranks);
      table = cfd.derivatives.table;
      j["trim"] = trim_json(cfd.trim);
      j["derivatives"] = derivatives_json(cfd.derivatives);
      j["cfd"] = cfd_study_json(cfd);
    } else {
        const auto model = make_aero_model(c);
      const TrimResult t = trim_or_evaluate(o, c, *model);
      if (!o.quiet && !t.solved) print_trim(c, t, seconds_since(t0));
      const DerivativeResult d = derivatives_with_control(c, *model, t.kinematics);
      table = d.table;
      j["trim"] = trim_json(t);
      j["derivatives"] = derivatives_json(d);
    }
  }
  if (!speaks(o)) return 0;
  const StabilityReport rep = stability_of(table, o.model);
  j["stability"] = stability_json(rep, o.model);
  j["wall_time_s"] = seconds_since(t0);
  const std::string text = j.dump(2) + "\n";
  std::vector<std::pair<std::string, std::string>> out;
  if (!o.json_path.empty()) out.emplace_back(o.json_path, text);
  if (!o.output_dir.empty()) {
    out.emplace_back(o.output_dir + "/stability.json", text);
    out.emplace_back(o.output_dir + "/stability.md", stability_markdown(rep));
  }
  write_files_atomic(out);
  if (!o.quiet) fmt::print("{}", stability_markdown(rep));
  return 0;
}

int run_analyze(const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case_for(o.case_path, "analyze");
  refuse_no_trim_with_cfd(o, c);
  const std::string dir = o.output_dir.empty() ? c.output_directory : o.output_dir;
  const auto model = make_aero_model(c);
  std::optional<CfdStudy> cfd;
  TrimResult t;
  DerivativeResult d;
  WrenchHistory history;
  if (c.aero.model == "cfd") {
    cfd = cfd_study(c, dir + "/cfd_runs", cfd_log(o), o.flow_ranks);
    t = cfd->trim;
    d = cfd->derivatives;
    history = cfd->history;
  } else {
    t = trim_or_evaluate(o, c, *model);
    d = derivatives_with_control(c, *model, t.kinematics);
    AeroRunOptions fine;
    fine.samples_per_cycle = 256;
    history = model->run(c.insect, t.kinematics, BodyMotion{}, fine);
  }
  if (!speaks(o)) return 0;
  const StabilityReport rep = stability_of(d.table, "6dof");
  // The time-periodic analysis and the revolving-wing comparison need an instantaneous model and a
  // symmetric insect; where they cannot run, the report says why and the rest is still written.
  std::vector<std::string> notices;
  std::optional<FloquetStudy> floquet;
  std::optional<RevolvingComparison> revolving;
  if (cfd) {
    notices.push_back("the cyclic-trim Floquet study, the revolving-wing comparison and the pitch-feedback analysis "
                      "need instantaneous loads (the quasi-steady model); with model = \"cfd\" the Floquet analysis "
                      "of the CFD A(t) is in the Navier-Stokes section, control derivatives are not computed from CFD");
  } else {
    try {
      floquet = floquet_study(c, *model, 0, &t, o.no_trim);
    } catch (const std::exception& e) {
      notices.push_back(std::string("Floquet analysis skipped: ") + e.what());
    }
  }
  if (!cfd && !c.kinematics.revolving()) {
    try {
      revolving = compare_with_revolving(c, t.kinematics, *model);
    } catch (const std::exception& e) {
      notices.push_back(std::string("revolving-wing comparison skipped: ") + e.what());
    }
  }
  std::optional<ControlSummary> control;
  if (floquet && c.control.type == "pitch" && !o.no_trim) {
    try {
      control = pitch_control_summary(c, *model, floquet->cyclic, floquet->averaged, floquet->phase);
    } catch (const SolveError& e) {
      notices.push_back(std::string("pitch-feedback analysis skipped: ") + e.what());
    }
  } else if (c.control.type == "pitch" && !cfd) {
    if (o.no_trim) notices.push_back("pitch-feedback analysis skipped: --no-trim (it needs the periodic hover orbit)");
    else
    notices.push_back("pitch-feedback analysis skipped: it needs the time-periodic hover (see the Floquet note)");
  }
  const double secs = seconds_since(t0);
  ReportInputs inputs;
  inputs.case_file = &c;
  inputs.trim = &t;
  inputs.derivatives = &d;
  inputs.stability = &rep;
  inputs.history = &history;
  inputs.wall_time_s = secs;
  inputs.floquet = floquet ? &*floquet : nullptr;
  inputs.revolving = revolving ? &*revolving : nullptr;
  inputs.control = control ? &*control : nullptr;
  inputs.notices = notices;
  if (cfd) inputs.extra_markdown = cfd_study_markdown(*cfd);
  const ReportFiles files = build_report(inputs);

  nlohmann::json j = metadata_json(c, "analyze");
  j["trim"] = trim_json(t);
  j["derivatives"] = derivatives_json(d);
  j["stability"] = stability_json(rep, "6dof");
  if (cfd) j["cfd"] = cfd_study_json(*cfd);
  j["wall_time_s"] = secs;
  if (!files.figure_notice.empty()) j["figure_notice"] = files.figure_notice;
  if (floquet) j["floquet"] = floquet_json(c, *floquet);
  if (revolving) j["revolving_comparison"] = revolving_json(*revolving, &rep);
  j["verdict"] = report_verdict(inputs);
  if (control) {
    auto lat = [](double tau) -> nlohmann::json {
      if (std::isnan(tau)) return nullptr;
      if (std::isinf(tau)) return "beyond the scanned range";
      return tau;
    };
    j["control"] = {{"description", control->description},
                    {"averaged_spectral_abscissa_per_s", {{"open_loop", control->open_abscissa}, {"closed_loop", control->closed_abscissa}}},
                    {"periodic_spectral_radius", {{"open_loop", control->open_radius}, {"closed_loop", control->closed_radius}}},
                    {"critical_latency_s", lat(control->critical.latency)},
                    {"best_pitch_gain", control->best.gain},
                    {"best_gain_critical_latency_s", lat(control->best.latency)},
                    {"scanned_latency_max_s", control->latency_max},
                    {"neutral_axis_z_m", control->neutral.z_at_com}};
  }
  j["notices"] = notices;
  // One header row, units in the column names (pandas.read_csv reads it with no options); axes in results.json.
  j["files"]["loads.csv"] = {{"rows", "the loads over the trimmed wingbeat, one row per sample"},
                             {"axes", "hover stability axes (x forward, y right, z down), moments about the "
                                      "wingbeat-mean centre of mass"},
                             {"units", "SI: s, N, N m, W"}};
  std::string csv = "t_s,X_N,Y_N,Z_N,L_N_m,M_N_m,N_N_m,Z_right_N,Z_left_N,power_W\n";
  for (const auto& s : history.samples) {
    const Wrench w = s.total();
    csv += fmt::format("{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", s.time, w.force.x(),
                       w.force.y(), w.force.z(), w.moment.x(), w.moment.y(), w.moment.z(), s.right.force.z(),
                       s.left.force.z(), s.power);
  }
  DerivativeTable table = d.table;
  table.source = c.path + " (" + d.table.source + ")";
  // Everything is computed; only now is the set written, as one (write_files_atomic: all or none, locked).
  std::vector<std::pair<std::string, std::string>> out = {{dir + "/results.json", j.dump(2) + "\n"},
                                                          {dir + "/derivatives.toml", derivative_table_toml(table)},
                                                          {dir + "/loads.csv", csv}};
  for (const auto& [name, svg] : files.figures) out.emplace_back(dir + "/" + name, svg);
  out.emplace_back(dir + "/report.md", files.markdown);
  out.emplace_back(dir + "/report.html", files.html);
  write_files_atomic(out);
  if (!o.quiet) {
    print_trim(c, t, secs);
    fmt::print("{}", stability_markdown(rep));
    if (!files.figure_notice.empty()) fmt::print("note: figures omitted: {}\n", files.figure_notice);
    fmt::print("wrote {}/report.md, report.html, results.json, derivatives.toml, loads.csv ({} figures) in {:.2f} s\n",
               dir, files.figures.size(), seconds_since(t0));
  }
  return 0;
}

int run_in_flow_groups(CommandOptions o, const std::string& name, int (*command)(const CommandOptions&)) {
  if (o.ranks_per_flow == 0) return command(o);
  const int k = o.ranks_per_flow, n = ns::Decomposition::launched_processes();
  if (n == 1 && k > 1)
    throw InputError("--ranks-per-flow", "",
                     fmt::format("{} ranks per flow need processes started by mpiexec; this is one process", k),
                     fmt::format("mpiexec -n N flapstab {} ... --ranks-per-flow {}, with N a multiple of {}", name, k,
                                 k));
  std::shared_ptr<const ns::Decomposition> job;
  try {
    job = ns::Decomposition::launched();
  } catch (const std::runtime_error& e) {  // several processes, but built without MPI
    throw InputError("--ranks-per-flow", "", e.what());
  }
  if (n % k != 0) {
    if (job->rank() != 0) return 2;  // rank 0 says why
    throw InputError("--ranks-per-flow", "",
                     fmt::format("{} ranks per flow, but mpiexec started {} processes: the groups must be whole", k, n),
                     fmt::format("mpiexec -n N flapstab {} ... --ranks-per-flow {}, with N a multiple of {}", name, k,
                                 k));
  }
  o.flow_ranks = job->split(k);
  return run_over_ranks(*o.flow_ranks, "flapstab " + name, [&] {
    if (!o.case_path.empty())  // (stability --derivatives TABLE runs no flow)
      if (const Case c = load_case(o.case_path); c.aero.model != "cfd")
        throw InputError(c.path, "aero.model",
                         fmt::format("--ranks-per-flow {} splits the CFD model's flows over MPI ranks; this case's "
                                     "model is '{}'", k, c.aero.model),
                         "model = \"cfd\" in [aero], or the command without --ranks-per-flow");
    return command(o);
  });
}

}  // namespace flapstab
