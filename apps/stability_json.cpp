// JSON and Markdown forms of stability results: every file names its axes, state order and units.
#include "apps/stability_json.hpp"
#include "apps/results_json.hpp"

#include <cmath>
#include <fmt/format.h>

namespace flapstab {

namespace {

using nlohmann::json;

json complex_json(std::complex<double> z) { return json::array({z.real(), z.imag()}); }

json optional_json(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

// What each non-dimensional state is, by name (docs/derivative-table.md scalings).
std::string state_unit(const std::string& s) {
  if (s == "u" || s == "v" || s == "w") return s + "/U";
  if (s == "p" || s == "q" || s == "r") return s + " c/U";
  if (s == "theta" || s == "phi" || s == "psi") return "rad";
  return "non-dimensional";
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string out;
  for (std::size_t i = 0; i < v.size(); ++i) out += (i ? sep : "") + v[i];
  return out;
}

json conventions_json() {
  return {
      {"axes", "hover stability axes: body-fixed, coinciding at trim with the inertial axes; x forward "
               "(horizontal), y right, z down; origin at the centre of mass; gravity +z"},
      {"state_orders", {{"longitudinal", {"u", "w", "q", "theta"}},
                        {"lateral", {"v", "p", "r", "phi"}},
                        {"6dof", {"u", "v", "w", "p", "q", "r", "phi", "theta"}}}},
      {"nondimensionalisation",
       "t+ = t U/c; u+ = u/U; p+ = p c/U; forces / (1/2 rho U^2 S_t); moments / (1/2 rho U^2 S_t c); "
       "m+ = m/(1/2 rho S_t c); I+ = I/(1/2 rho S_t c^3); g+ = g c/U^2; lambda+ = lambda c/U"},
      {"system", "d/dt+ x = A x, A = system_matrix_nd (rows and columns in state_order)"},
      {"names", "name: the rigid-body motions (pitch, roll, yaw, surge, sway, heave) whose size in comparable "
                "non-dimensional units (velocities / U; rotations as the wing-tip speed they give, R/c x rate x c / U, "
                "the rate or lambda+ x attitude) is at least 0.3 of the largest (motion_magnitude), in that fixed order, then oscillation (prefixed stable/unstable), "
                "subsidence, divergence or neutral mode; prefixed fast/slow only where two modes of one analysis would "
                "share a name. The same root has the same name in every analysis; modes of two analyses are paired by "
                "eigenvector similarity (docs/theory/modes.md)"},
      {"labels", "oscillatory (complex pair, reported by its Im > 0 member) | subsidence (stable real) | "
                 "divergence (unstable real) | neutral (|Re| within tolerance of 0); prefixed stable/unstable; "
                 "ranked fast/slow (intermediate between) by |lambda| among modes sharing a label"},
      {"eigenvector", "components in the non-dimensional states, scaled so that the attitude component "
                      "(theta or phi, the larger) is 1, or the largest component where that is negligible "
                      "(see normalised_by); phase in degrees relative to it"},
      {"time_to_half_double", "ln 2 / |Re lambda| (amplitude envelope); time_to_half for stable modes, "
                              "time_to_double for unstable ones, the other null"},
      {"natural_frequency", "|lambda| for every root (as MATLAB/python-control damp)"},
  };
}

json units_json() {
  return {{"eigenvalue_nd", "per unit t+ (c/U)"}, {"eigenvalue_per_s", "1/s"},
          {"eigenvalue_per_wingbeat", "per wingbeat period (1/frequency)"},
          {"natural_frequency_hz", "Hz"}, {"natural_frequency_rad_s", "rad/s"},
          {"period_s", "s"}, {"time_to_double_s", "s"}, {"time_to_half_s", "s"},
          {"time_constant_s", "s"}, {"_wingbeats", "wingbeat periods"}, {"_nd", "units of t+ = t U/c"},
          {"reference", "SI (U m/s, c m, S_t m^2, rho kg/m^3, frequency Hz, g m/s^2)"}};
}

std::string fmt_num(double v) { return fmt::format("{:.4g}", v); }
std::string fmt_opt(const std::optional<double>& v) { return v ? fmt_num(*v) : "—"; }
std::string fmt_complex(std::complex<double> z) {
  if (z.imag() == 0) return fmt_num(z.real());
  return fmt::format("{:.4g} ± {:.4g}i", z.real(), std::abs(z.imag()));
}

}  // namespace

json to_json(const Mode& m, const std::vector<std::string>& states) {
  json vec = json::array(), mag = json::array(), phase = json::array();
  for (const auto& z : m.eigenvector) {
    vec.push_back(complex_json(z));
    mag.push_back(std::abs(z));
    phase.push_back(std::arg(z) * 180.0 / pi);
  }
  json magnitude = json::object();
  for (const auto& [motion, r] : m.motion_magnitude) magnitude[motion] = r;
  return {
      {"name", m.name},
      {"motions", m.motions},
      {"motion_magnitude", magnitude},
      {"label", m.label},
      {"kind", to_string(m.kind)},
      {"stability", to_string(m.stability)},
      {"speed_rank", m.speed_rank.empty() ? json(nullptr) : json(m.speed_rank)},
      {"conjugate_pair", m.conjugate_pair},
      {"eigenvalue_nd", complex_json(m.eigenvalue_nd)},
      {"eigenvalue_per_s", complex_json(m.eigenvalue_per_s)},
      {"eigenvalue_per_wingbeat", complex_json(m.eigenvalue_per_wingbeat)},
      {"damping_ratio", optional_json(m.damping_ratio)},
      {"natural_frequency_nd", m.natural_frequency_nd},
      {"natural_frequency_rad_s", m.natural_frequency_rad_s},
      {"natural_frequency_hz", m.natural_frequency_hz},
      {"period_nd", optional_json(m.period_nd)},
      {"period_s", optional_json(m.period_s)},
      {"period_wingbeats", optional_json(m.period_wingbeats)},
      {"time_constant_s", optional_json(m.time_constant_s)},
      {"time_to_double_nd", optional_json(m.time_to_double_nd)},
      {"time_to_double_s", optional_json(m.time_to_double_s)},
      {"time_to_double_wingbeats", optional_json(m.time_to_double_wingbeats)},
      {"time_to_half_nd", optional_json(m.time_to_half_nd)},
      {"time_to_half_s", optional_json(m.time_to_half_s)},
      {"time_to_half_wingbeats", optional_json(m.time_to_half_wingbeats)},
      {"eigenvector", vec},
      {"eigenvector_magnitude", mag},
      {"eigenvector_phase_deg", phase},
      {"normalised_by", m.normalised_by},
      {"participation", m.participation},
      {"dominant_states", m.dominant_states},
      {"state_order", states},
  };
}

json to_json(const StabilityAnalysis& a) {
  json units = json::array();
  for (const auto& s : a.state_order) units.push_back(state_unit(s));
  json modes = json::array();
  for (const auto& m : a.modes) modes.push_back(to_json(m, a.state_order));
  return {{"state_order", a.state_order},
          {"state_units", units},
          {"system_matrix_nd", matrix_json(a.system_matrix_nd)},
          {"input_order", a.input_order},
          {"input_matrix_nd", a.input_matrix_nd.cols() > 0 ? matrix_json(a.input_matrix_nd) : json::array()},
          {"input_note", "d/dt+ x = A x + B delta: delta in each input's unit (deg or Hz), columns in input_order"},
          {"time_scale_s", a.reference.time_scale()},
          {"wingbeat_frequency_hz", a.reference.frequency},
          {"participation_measure", a.participation_measure},
          {"modes", modes}};
}

std::vector<SubsystemMatch> subsystem_correspondence(const StabilityReport& r) {
  std::vector<SubsystemMatch> out;
  if (!r.coupled) return out;
  for (std::size_t i = 0; i < r.coupled->modes.size(); ++i) out.push_back({i, "", 0, "", 0});
  for (const auto* sub : {&r.longitudinal, &r.lateral}) {
    if (!*sub) continue;
    for (const ModePair& p : pair_modes(*r.coupled, **sub))
      if (p.b && p.similarity > out[p.a].similarity)
        out[p.a] = {p.a, (*sub)->name, *p.b, (*sub)->modes[*p.b].name, p.similarity};
  }
  return out;
}

json to_json(const StabilityReport& r) {
  const auto& ref = r.reference;
  const auto& nd = r.nondimensional;
  json j = {{"conventions", conventions_json()},
            {"units", units_json()},
            {"source", r.source},
            {"reference", {{"U", ref.U}, {"c", ref.c}, {"S_t", ref.S_t}, {"rho", ref.rho},
                           {"frequency", ref.frequency}, {"g", ref.g}}},
            {"nondimensional_parameters", {{"m_plus", nd.m}, {"Ixx_plus", nd.Ixx}, {"Iyy_plus", nd.Iyy},
                                           {"Izz_plus", nd.Izz}, {"Ixz_plus", nd.Ixz}, {"g_plus", nd.g},
                                           {"time_scale_s", nd.time_scale_s}}}};
  j["longitudinal"] = r.longitudinal ? to_json(*r.longitudinal) : json(nullptr);
  j["lateral"] = r.lateral ? to_json(*r.lateral) : json(nullptr);
  if (r.six_dof_requested) {
    j["6dof"] = r.coupled ? to_json(*r.coupled) : json(nullptr);
    if (r.coupled)
      for (const auto& c : subsystem_correspondence(r)) {
        json& m = j["6dof"]["modes"][c.coupled];
        m["subsystem_mode"] = c.analysis.empty() ? json(nullptr)
                                                 : json{{"analysis", c.analysis}, {"index", c.index},
                                                        {"name", c.name}, {"similarity", c.similarity}};
      }
  }
  j["notices"] = r.notices;
  return j;
}

std::string modes_markdown(const StabilityAnalysis& a) {
  std::vector<std::string> units;
  for (const auto& s : a.state_order) units.push_back(s + " (" + state_unit(s) + ")");
  std::string md = fmt::format(
      "State order [{}]: {}. Hover stability axes (x forward, y right, z down). Eigenvalues λ⁺ per unit "
      "t⁺ = tU/c (c/U = {:.4g} s) and in s⁻¹; times in seconds and wingbeats ({:.4g} Hz); "
      "eigenvectors scaled to the attitude component; dominant states by participation; modes named by the "
      "rigid-body motions of their eigenvectors (docs/theory/modes.md).\n\n",
      join(a.state_order, ", "), join(units, ", "), a.reference.time_scale(), a.reference.frequency);
  md += "| mode | λ⁺ | λ (1/s) | ζ | ωn (Hz) | period (s) | period (wingbeats) | t½ or t×2 (s) | "
        "t½ or t×2 (wingbeats) | dominant states |\n";
  md += "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& m : a.modes) {
    std::string t_s = "—", t_wb = "—";
    if (m.time_to_half_s) t_s = "t½ " + fmt_num(*m.time_to_half_s), t_wb = "t½ " + fmt_num(*m.time_to_half_wingbeats);
    if (m.time_to_double_s)
      t_s = "t×2 " + fmt_num(*m.time_to_double_s), t_wb = "t×2 " + fmt_num(*m.time_to_double_wingbeats);
    md += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", m.name, fmt_complex(m.eigenvalue_nd),
                      fmt_complex(m.eigenvalue_per_s), fmt_opt(m.damping_ratio), fmt_num(m.natural_frequency_hz),
                      fmt_opt(m.period_s), fmt_opt(m.period_wingbeats), t_s, t_wb, join(m.dominant_states, ", "));
  }
  return md;
}

std::string stability_markdown(const StabilityReport& r) {
  std::string md;
  auto section = [&](const char* title, const std::optional<StabilityAnalysis>& a) {
    if (a) md += fmt::format("### {} modes\n\n{}\n", title, modes_markdown(*a));
  };
  section("Longitudinal", r.longitudinal);
  section("Lateral", r.lateral);
  section("Coupled 6DoF", r.coupled);
  if (r.coupled && (r.longitudinal || r.lateral)) {
    std::vector<std::string> pairs;
    for (const auto& c : subsystem_correspondence(r))
      pairs.push_back(c.analysis.empty()
                          ? fmt::format("{}: no subsystem mode", r.coupled->modes[c.coupled].name)
                          : fmt::format("{}: {} {} ({:.3f})", r.coupled->modes[c.coupled].name, c.analysis, c.name,
                                        c.similarity));
    md += "Coupled modes and the subsystem modes they are, paired by eigenvector similarity (1 = the same shape): " +
          join(pairs, "; ") + ".\n\n";
  }
  if (!r.notices.empty()) {
    md += "Notices:\n\n";
    for (const auto& n : r.notices) md += "- " + n + "\n";
  }
  return md;
}

}  // namespace flapstab
