// flapstab floquet: periodic hover (cyclic trim, phase-resolved derivatives, Floquet modes) beside the averaged LTI model.
#include "apps/floquet_command.hpp"

#include <chrono>
#include <fmt/format.h>

#include "apps/results_json.hpp"
#include "apps/stability_json.hpp"
#include "cfd/aero_factory.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "flight/hover_model.hpp"
#include "trim/translation.hpp"

namespace flapstab {

namespace {

using nlohmann::json;
using cplx = std::complex<double>;

const std::vector<int> longitudinal_states{0, 2, 4, 7};  // in [u v w p q r phi theta]
const std::vector<int> lateral_states{1, 3, 5, 6};

Eigen::MatrixXd block(const Eigen::Matrix<double, 8, 8>& m, const std::vector<int>& idx) {
  Eigen::MatrixXd b(Eigen::Index(idx.size()), Eigen::Index(idx.size()));
  for (std::size_t i = 0; i < idx.size(); ++i)
    for (std::size_t j = 0; j < idx.size(); ++j) b(Eigen::Index(i), Eigen::Index(j)) = m(idx[i], idx[j]);
  return b;
}

FloquetSubsystem subsystem(const std::string& name, const std::vector<int>& idx, const FloquetStudy& s,
                           const std::optional<StabilityAnalysis>& lti, const ReferenceQuantities& ref) {
  std::vector<std::string> order;
  for (int i : idx) order.push_back(linear_state_names()[std::size_t(i)]);
  const Eigen::VectorXd scale = nondimensional_state_scale(order, ref);
  const double T = s.cyclic.period;
  FloquetSubsystem f;
  const PeriodicMatrixSpline A(T, s.phase.system_samples(idx));
  f.integration = monodromy([&](double t) { return A(t); }, Eigen::Index(idx.size()), T);
  f.phase_resolved = floquet_analysis(name, order, f.integration.monodromy, T, scale, ref);
  f.has_flow_sensitivity = !s.no_trim;
  f.flow_sensitivity = s.no_trim ? f.phase_resolved
                                 : floquet_analysis(name, order, block(s.cyclic.monodromy, idx), T, scale, ref);
  for (std::size_t i = 0; i < idx.size() && f.has_flow_sensitivity; ++i)
    f.max_multiplier_difference = std::max(
        f.max_multiplier_difference, std::abs(f.phase_resolved.multipliers[i] - f.flow_sensitivity.multipliers[i]));
  f.lti = lti;
  if (lti) {
    f.lti_eigenvalues_nd = Eigen::EigenSolver<Eigen::MatrixXd>(lti->system_matrix_nd).eigenvalues();
    f.lti_pairing = pair_modes(f.phase_resolved.modes, *lti);
  }
  return f;
}

json complex_list(const std::vector<cplx>& v) {
  json j = json::array();
  for (const cplx& z : v) j.push_back({z.real(), z.imag()});
  return j;
}

json analysis_json(const FloquetAnalysis& f) {
  json j = {{"state_order", f.state_order},
            {"period_s", f.period_s},
            {"monodromy_si", matrix_json(f.monodromy_si)},
            {"monodromy_nd", matrix_json(f.monodromy_nd)},
            {"multipliers", complex_list(f.multipliers)},
            {"exponents_per_s", complex_list(f.exponents_per_s)},
            {"exponents_nd", complex_list(f.exponents_nd)},
            {"exponents_per_wingbeat", complex_list(f.exponents_per_wingbeat)},
            {"notices", f.notices}};
  j["modes"] = f.modes.modes.empty() ? json::array() : to_json(f.modes)["modes"];
  return j;
}

json subsystem_json(const FloquetSubsystem& f) {
  json j = analysis_json(f.phase_resolved);
  j["route"] = "phase_resolved (route 1)";
  j["lti_eigenvalues_nd"] = json::array();
  for (Eigen::Index i = 0; i < f.lti_eigenvalues_nd.size(); ++i)
    j["lti_eigenvalues_nd"].push_back({f.lti_eigenvalues_nd(i).real(), f.lti_eigenvalues_nd(i).imag()});
  if (f.lti) j["lti_modes"] = to_json(*f.lti)["modes"];
  j["mode_pairing"] = json::array();
  for (const ModePair& p : f.lti_pairing)
    j["mode_pairing"].push_back({{"floquet_mode", p.a},
                                 {"floquet_name", f.phase_resolved.modes.modes[p.a].name},
                                 {"lti_mode", p.b ? json(*p.b) : json(nullptr)},
                                 {"lti_name", p.b ? json(f.lti->modes[*p.b].name) : json(nullptr)},
                                 {"similarity", p.similarity}});
  j["mode_pairing_note"] = "each Floquet mode (index in modes) beside the averaged mode (index in lti_modes) of the "
                           "most similar eigenvector: greedy-best one-to-one pairing by |m_a^H m_b| / (|m_a| |m_b|) "
                           "of the motion vectors (docs/theory/modes.md)";
  j["routes"] = {{"phase_resolved",
                  {{"description", "Phi' = A(t) Phi over one wingbeat with CVODE (rtol 1e-10), A(t) a periodic cubic "
                                   "spline through the phase-resolved linearisations"},
                   {"cvode_steps", f.integration.steps},
                   {"multipliers", complex_list(f.phase_resolved.multipliers)},
                   {"exponents_nd", complex_list(f.phase_resolved.exponents_nd)}}},
                 {"flow_sensitivity", analysis_json(f.flow_sensitivity)},
                 {"max_multiplier_difference", f.max_multiplier_difference}};
  j["routes"]["flow_sensitivity"]["description"] =
      "d x(T) / d x(0) of the nonlinear free system about the cyclic orbit, CVODES forward sensitivities (rtol 1e-12)";
  if (!f.has_flow_sensitivity) {
    j["routes"]["flow_sensitivity"] = nullptr;
    j["routes"]["max_multiplier_difference"] = nullptr;
    j["routes"]["note"] = "--no-trim: no periodic orbit, so no flow-sensitivity route; A(t) linearises the equations "
                          "of motion about the body held at rest at the case's kinematics";
  }
  return j;
}

std::string fmt_c(cplx z) { return fmt::format("{:+.5f} {:+.5f}i", z.real(), z.imag()); }

void print_subsystem(const char* title, const FloquetSubsystem& f) {
  fmt::print("{} ({}; non-dimensional per t+ = t U / c, and per wingbeat):\n", title,
             fmt::join(f.phase_resolved.state_order, ", "));
  fmt::print("  {:<40} {:>26} {:>26} {:>12}  {}\n", "Floquet mode", "exponent (nd)", "log(mu) per wingbeat", "|mu|",
             "averaged mode (eigenvector similarity)");
  for (const ModePair& p : f.lti_pairing) {
    const Mode& m = f.phase_resolved.modes.modes[p.a];
    fmt::print("  {:<40} {:>26} {:>26} {:>12.6f}  {}\n", m.name, fmt_c(m.eigenvalue_nd), fmt_c(m.eigenvalue_per_wingbeat),
               std::exp(m.eigenvalue_per_wingbeat.real()),
               p.b ? fmt::format("{} ({:.3f})", f.lti->modes[*p.b].name, p.similarity) : std::string("-"));
  }
  if (f.lti_pairing.empty())
    for (const Mode& m : f.phase_resolved.modes.modes)
      fmt::print("  {:<40} {:>26} {:>26} {:>12.6f}\n", m.name, fmt_c(m.eigenvalue_nd), fmt_c(m.eigenvalue_per_wingbeat),
                 std::exp(m.eigenvalue_per_wingbeat.real()));
  if (f.lti)
    for (const Mode& m : f.lti->modes)
      fmt::print("  LTI {:<36} {:>26} {:>26}\n", m.name, fmt_c(m.eigenvalue_nd), fmt_c(m.eigenvalue_per_wingbeat));
  for (const auto& n : f.phase_resolved.notices) fmt::print("  note: {}\n", n);
  if (f.has_flow_sensitivity) fmt::print("  routes agree: max |mu_phase - mu_flow| = {:.2e}\n", f.max_multiplier_difference);
}

// A trim's parameters as written in floquet.json: the cyclic trim's value beside the averaged trim's.
json parameters_json(const std::vector<TrimParameterValue>& parameters) {
  json params = json::array();
  for (const auto& p : parameters)
    params.push_back({{"name", p.label}, {"unit", p.unit}, {"value", p.value}, {"averaged_trim_value", p.initial},
                      {"lower", p.lower}, {"upper", p.upper}});
  return params;
}

json residuals_json(const std::vector<std::string>& names, const Eigen::VectorXd& values) {
  json residuals = json::object();
  for (std::size_t i = 0; i < names.size(); ++i) residuals[names[i]] = values(Eigen::Index(i));
  return residuals;
}

// The outcome of a shooting trim (CyclicTrimResult, TranslationTrimResult): the keys both write under "cyclic_trim".
template <class ShootingResult>
json shooting_json(const ShootingResult& r, const std::string& residual_scaling) {
  return {{"converged", r.converged},
          {"residual", r.residual},
          {"residual_scaling", residual_scaling},
          {"residuals", residuals_json(r.residual_names, r.residuals)},
          {"iterations", r.iterations},
          {"integrations", r.integrations},
          {"message", r.message},
          {"period_s", r.period},
          {"parameters", parameters_json(r.parameters)},
          {"kinematics", kinematics_json(r.kinematics)}};
}

// What every free-model floquet.json holds after its trim: the averaged derivatives, the phase-resolved derivatives
// (taken `about` what the caller says), both subsystems (the longitudinal one's keys also at the top level) and the
// wall time.
void add_study_json(json& j, const FloquetStudy& s, const std::string& about) {
  j["derivatives"] = derivatives_json(s.averaged);
  j["phase_resolved_derivatives"] = {{"phases", s.phase.samples.size()},
                                     {"relative_step", s.phase.relative_step},
                                     {"velocity_step_m_s", s.phase.velocity_step},
                                     {"rate_step_rad_s", s.phase.rate_step},
                                     {"about", about},
                                     {"cycle_mean_nd", matrix_json(s.phase.mean_wrench_nd())}};
  const json lon_j = subsystem_json(s.longitudinal);
  for (auto it = lon_j.begin(); it != lon_j.end(); ++it) j[it.key()] = it.value();
  j["longitudinal"] = lon_j;
  j["lateral"] = subsystem_json(s.lateral);
  j["wall_time_s"] = s.wall_time_s;
}

// floquet.json to --json FILE and/or DIR/floquet.json (atomic, both or neither).
void write_floquet_json(const CommandOptions& o, const std::string& text) {
  std::vector<std::pair<std::string, std::string>> out;
  if (!o.json_path.empty()) out.emplace_back(o.json_path, text);
  if (!o.output_dir.empty()) out.emplace_back(o.output_dir + "/floquet.json", text);
  write_files_atomic(out);
}

void print_study(const FloquetStudy& s, std::chrono::steady_clock::time_point t0) {
  print_subsystem("longitudinal", s.longitudinal);
  print_subsystem("lateral", s.lateral);
  fmt::print("done in {:.2f} s\n", seconds_since(t0));
}

// The study's analyses once its averaged derivatives and phase-resolved derivatives are in: both subsystems beside the
// averaged model's modes, and the wall time since t0.
void finish_study(FloquetStudy& s, std::chrono::steady_clock::time_point t0) {
  const StabilityReport lti = analyse_stability(s.averaged.table);
  const ReferenceQuantities& ref = s.averaged.table.reference;
  s.longitudinal = subsystem("longitudinal", longitudinal_states, s, lti.longitudinal, ref);
  s.lateral = subsystem("lateral", lateral_states, s, lti.lateral, ref);
  s.wall_time_s = seconds_since(t0);
}

}  // namespace

FloquetStudy floquet_study(const Case& c, const AeroModel& model, int phases, const TrimResult* averaged,
                           bool no_trim) {
  const auto t0 = std::chrono::steady_clock::now();
  if (no_trim) {
    // The case's kinematics as they are: the residual reported, the averaged derivatives there, and A(t) about the
    // body held at rest (an orbit of zeros) - the linearisation the periodic analysis has when the hover is not
    // balanced and there is no periodic orbit to linearise about.
    check_cyclic_trim_case(c, model);
    FloquetStudy s;
    s.no_trim = true;
    s.averaged_trim = averaged ? *averaged : evaluate_at_case_kinematics(c, model);
    s.averaged = cycle_averaged_derivatives(model, c.insect, c.kinematics, c.fluid, c.derivatives.relative_step);
    s.cyclic.kinematics = c.kinematics;
    s.cyclic.period = c.kinematics.period();
    s.cyclic.message = "not solved (--no-trim)";
    const int N = phases > 0 ? phases : c.aero.quasi_steady.samples_per_cycle;
    const InstantaneousAero aero(model, c.insect, c.kinematics);
    s.phase = phase_resolved_derivatives(aero, std::vector<BodyStateVector>(std::size_t(N), BodyStateVector::Zero()),
                                         s.averaged.table.reference, c.derivatives.relative_step);
    finish_study(s, t0);
    return s;
  }
  // The averaged trim, cyclic trim, derivatives at the cyclic trim's kinematics (so both analyses see the same
  // wingbeat), orbit and phase-resolved derivatives: flight/hover_model.hpp computes them once for every user.
  HoverModel h = hover_model(c, model, {}, phases, {}, averaged);
  FloquetStudy s;
  s.averaged_trim = std::move(h.averaged_trim);
  s.cyclic = std::move(h.cyclic);
  s.averaged = std::move(h.derivatives);
  s.phase = std::move(h.phase);
  finish_study(s, t0);
  return s;
}

json floquet_json(const Case& c, const FloquetStudy& s) {
  json j = metadata_json(c, "floquet");
  const CyclicTrimResult& ct = s.cyclic;
  if (s.no_trim) {
    j["cyclic_trim"] = {{"solved", false},
                        {"note", "--no-trim: the case's kinematics as given; no periodic orbit is sought and A(t) "
                                 "linearises the equations of motion about the body held at rest"},
                        {"period_s", ct.period},
                        {"kinematics", kinematics_json(ct.kinematics)}};
    j["averaged_trim"] = trim_json(s.averaged_trim);
    j["residual"] = {{"force_N", {s.averaged_trim.force_residual.x(), s.averaged_trim.force_residual.y(),
                                  s.averaged_trim.force_residual.z()}},
                     {"moment_N_m", {s.averaged_trim.moment_residual.x(), s.averaged_trim.moment_residual.y(),
                                     s.averaged_trim.moment_residual.z()}},
                     {"force_relative_to_weight", s.averaged_trim.relative_force_residual},
                     {"moment_relative_to_weight_times_wing_length", s.averaged_trim.relative_moment_residual}};
    add_study_json(j, s, "the body held at rest at the case's kinematics (--no-trim)");
    return j;
  }
  const std::vector<std::string> lon{"u", "w", "q", "theta"};
  json amp_si = json::object(), amp_nd = json::object(), mean_si = json::object();
  for (int i = 0; i < 4; ++i) {
    amp_si[lon[std::size_t(i)]] = ct.amplitude_si(i);
    amp_nd[lon[std::size_t(i)]] = ct.amplitude_nd(i);
    mean_si[lon[std::size_t(i)]] = ct.mean_si(i);
  }
  const BodyStateVector& x0 = ct.initial_state;
  j["cyclic_trim"] = shooting_json(ct, "velocities / U, rates * c / U, angles rad, drifts / c; max-norm");
  j["cyclic_trim"].update(json{
      {"initial_state", {{"u_m_s", x0(3)}, {"w_m_s", x0(5)}, {"q_rad_s", x0(7)}, {"theta_rad", x0(10)}}},
      {"mean_theta_rad", ct.mean_theta},
      {"attitude", ct.free_attitude ? "free" : "imposed"},
      {"mean_body_angle_deg", ct.mean_body_angle / deg},
      {"attitude_note", ct.free_attitude
                            ? "[trim] cyclic_attitude = \"free\": body_angle_deg held at the averaged trim's value, "
                              "the orbit's mean pitch theta its own; mean attitude = body angle + mean theta"
                            : "the orbit's mean pitch theta imposed as zero: mean attitude = the body angle"},
      {"oscillation_amplitude_si", amp_si},
      {"oscillation_amplitude_nd", amp_nd},
      {"oscillation_note", "half peak-to-peak over the wingbeat (m/s, rad/s, rad; nd: / U, * c / U, rad)"},
      {"cycle_mean_si", mean_si},
      {"symmetry_residual", ct.symmetry_residual}});
  j["averaged_trim"] = trim_json(s.averaged_trim);
  add_study_json(j, s, "the cyclic orbit (each phase's own body velocity and rates)");
  return j;
}

// [body_motion] model = "translation-only": the averaged trim as the start, the translation-only cyclic trim, and the
// Floquet exponents of [u, v, w] from its monodromy (trim/translation.hpp).
int run_translation_floquet(const Case& c, const AeroModel& model, const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (o.no_trim)
    throw InputError(c.path, "body_motion", "--no-trim is not available with the translation-only model",
                     "the translation-only cyclic trim (without --no-trim)");
  check_translation_case(c, model);
  const TrimResult averaged = trim_hover(c, model);
  const TranslationTrimResult tr = translation_cyclic_trim(c, model, averaged.kinematics);
  if (!tr.converged)
    throw SolveError(fmt::format("{}: the translation-only cyclic trim did not converge ({}; residual {:.2e})", c.path,
                                 tr.message, tr.residual));
  const ReferenceQuantities ref = reference_quantities(c.insect, tr.kinematics, c.fluid);
  const std::vector<std::string> order{"u", "v", "w"};
  const FloquetAnalysis f = floquet_analysis("translation", order, tr.monodromy, tr.period,
                                             nondimensional_state_scale(order, ref), ref);
  json j = metadata_json(c, "floquet");
  j["model"] = "translation-only";
  j["model_note"] = "attitude prescribed (the trimmed attitude turned by [body_motion]'s roll, pitch and yaw series), "
                    "position and velocity free; the force equations only (docs/case-file.md [body_motion])";
  const Vec3 &v0 = tr.initial_velocity, &vm = tr.mean_velocity;
  j["cyclic_trim"] = shooting_json(tr, "velocities / U, drifts / c; max-norm");
  j["cyclic_trim"]["initial_velocity_m_s"] = {v0.x(), v0.y(), v0.z()};
  j["cyclic_trim"]["cycle_mean_velocity_m_s"] = {vm.x(), vm.y(), vm.z()};
  j["averaged_trim"] = trim_json(averaged);
  const json a = analysis_json(f);
  for (auto it = a.begin(); it != a.end(); ++it) j[it.key()] = it.value();
  j["route"] = "flow_sensitivity: d[u v w](T) / d[u v w](0) of the translation-only system about its cyclic orbit, "
               "CVODES forward sensitivities (rtol 1e-12)";
  j["wall_time_s"] = seconds_since(t0);
  write_floquet_json(o, j.dump(2) + "\n");
  if (!o.quiet) {
    fmt::print("{}: translation-only cyclic trim of '{}': residual {:.2e} after {} Newton iterations ({} integrations)\n",
               c.path, c.insect.name, tr.residual, tr.iterations, tr.integrations);
    for (const auto& p : tr.parameters)
      fmt::print("  {:<24} {:>12.6f} {:<3} (averaged trim {:.6f})\n", p.label, p.value, p.unit, p.initial);
    fmt::print("translation (u, v, w; non-dimensional per t+ = t U / c, and per wingbeat):\n");
    for (const Mode& m : f.modes.modes)
      fmt::print("  {:<40} {:>26} {:>26} {:>12.6f}\n", m.name, fmt_c(m.eigenvalue_nd), fmt_c(m.eigenvalue_per_wingbeat),
                 std::exp(m.eigenvalue_per_wingbeat.real()));
    fmt::print("done in {:.2f} s\n", seconds_since(t0));
  }
  return 0;
}

int run_floquet(const CommandOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const Case c = load_case(o.case_path);
  const auto model = make_aero_model(c);
  if (c.body_motion.present) return run_translation_floquet(c, *model, o);
  if (o.no_trim && c.aero.model == "cfd")
    throw InputError(c.path, "aero.model", "--no-trim is not available with the CFD model",
                     "model = \"quasi-steady\" for --no-trim");
  const FloquetStudy s = floquet_study(c, *model, 0, nullptr, o.no_trim);
  write_floquet_json(o, floquet_json(c, s).dump(2) + "\n");
  if (!o.quiet && s.no_trim) {
    const TrimResult& t = s.averaged_trim;
    fmt::print("{}: '{}' NOT TRIMMED (--no-trim): residual force {:.3e} x weight, moment {:.3e} x weight x R; A(t) "
               "about the body held at rest\n", c.path, c.insect.name, t.relative_force_residual,
               t.relative_moment_residual);
    print_study(s, t0);
  } else if (!o.quiet) {
    const CyclicTrimResult& ct = s.cyclic;
    fmt::print("{}: cyclic hover trim of '{}': residual {:.2e} after {} Newton iterations ({} integrations)\n", c.path,
               c.insect.name, ct.residual, ct.iterations, ct.integrations);
    for (const auto& p : ct.parameters)
      fmt::print("  {:<24} {:>12.6f} {:<3} (averaged trim {:.6f})\n", p.label, p.value, p.unit, p.initial);
    fmt::print("  initial state u {:.4e} m/s, w {:.4e} m/s, q {:.4e} rad/s, theta {:.4e} rad\n", ct.initial_state(3),
               ct.initial_state(5), ct.initial_state(7), ct.initial_state(10));
    fmt::print("  mean attitude {:.6f} deg (body long axis above the horizontal; {}: body angle {:.6f} deg + mean "
               "theta {:.6f} deg)\n",
               ct.mean_body_angle / deg, ct.free_attitude ? "free, the orbit's own" : "imposed",
               ct.kinematics.body_angle / deg, ct.mean_theta / deg);
    fmt::print("  within-cycle oscillation (half peak-to-peak): u {:.3e} m/s, w {:.3e} m/s, q {:.3e} rad/s, theta "
               "{:.3e} rad ({:.3f} deg)\n",
               ct.amplitude_si(0), ct.amplitude_si(1), ct.amplitude_si(2), ct.amplitude_si(3),
               ct.amplitude_si(3) / deg);
    print_study(s, t0);
  }
  return 0;
}

}  // namespace flapstab
