// The analysis report: Markdown with figures, and the same as one self-contained HTML page.
#include "apps/report.hpp"

#include <cmath>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sstream>

#include "apps/floquet_command.hpp"
#include "apps/plots.hpp"
#include "apps/results_json.hpp"
#include "apps/revolving.hpp"
#include "apps/stability_json.hpp"

namespace flapstab {

namespace {

std::string html_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else o += c;
  }
  return o;
}

// Inline markup: `code`, **bold**.
std::string inline_html(const std::string& s) {
  std::string e = html_escape(s), o;
  bool code = false, bold = false;
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (e[i] == '`') {
      o += code ? "</code>" : "<code>";
      code = !code;
    } else if (!code && e.compare(i, 2, "**") == 0) {
      o += bold ? "</strong>" : "<strong>";
      bold = !bold;
      ++i;
    } else {
      o += e[i];
    }
  }
  return o;
}

std::vector<std::string> table_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cur;
  for (std::size_t i = 1; i < line.size(); ++i) {
    if (line[i] == '|') {
      cells.push_back(cur);
      cur.clear();
    } else {
      cur += line[i];
    }
  }
  for (auto& c : cells) {
    while (!c.empty() && c.front() == ' ') c.erase(c.begin());
    while (!c.empty() && c.back() == ' ') c.pop_back();
  }
  return cells;
}

std::string complex_str(std::complex<double> z) {
  if (std::abs(z.imag()) < 1e-12) return fmt::format("{:.4g}", z.real());
  return fmt::format("{:.4g} ± {:.4g}i", z.real(), std::abs(z.imag()));
}

std::string similarity_str(const ModePair& p) { return p.b ? fmt::format("{:.3f}", p.similarity) : std::string("—"); }

// Floquet exponents beside the averaged LTI mode of the most similar eigenvector, one row per mode (conjugates once).
std::string floquet_table(const FloquetSubsystem& f) {
  std::string md = "| Floquet mode | exponent λ⁺ | log μ per wingbeat | multiplier modulus | averaged LTI mode | LTI λ⁺ | "
                   "eigenvector similarity |\n|---|---|---|---|---|---|---|\n";
  const auto& fm = f.phase_resolved.modes.modes;
  for (std::size_t i = 0; i < fm.size(); ++i) {
    const Mode& m = fm[i];
    std::string lti_name = "—", lti_value = "—", similarity = "—";
    if (f.lti && i < f.lti_pairing.size() && f.lti_pairing[i].b) {
      const Mode& a = f.lti->modes[*f.lti_pairing[i].b];
      lti_name = a.name;
      lti_value = complex_str(a.eigenvalue_nd);
      similarity = similarity_str(f.lti_pairing[i]);
    }
    md += fmt::format("| {} | {} | {} | {:.4g} | {} | {} | {} |\n", m.name, complex_str(m.eigenvalue_nd),
                      complex_str(m.eigenvalue_per_wingbeat), std::exp(m.eigenvalue_per_wingbeat.real()), lti_name,
                      lti_value, similarity);
  }
  return md;
}

// Each flapping mode beside the revolving flyer's mode of the most similar eigenvector; revolving modes left
// unpaired (it has more) follow.
std::string mode_comparison_table(const StabilityAnalysis& a, const StabilityAnalysis& b) {
  std::string md = "| flapping mode | λ⁺ | t×2 or t½ (s) | revolving mode | λ⁺ | t×2 or t½ (s) | eigenvector similarity "
                   "|\n|---|---|---|---|---|---|---|\n";
  auto time = [](const Mode& m) {
    if (m.time_to_double_s) return fmt::format("t×2 {:.3g}", *m.time_to_double_s);
    if (m.time_to_half_s) return fmt::format("t½ {:.3g}", *m.time_to_half_s);
    return std::string("—");
  };
  auto cells = [&](const Mode& m) { return fmt::format("{} | {} | {}", m.name, complex_str(m.eigenvalue_nd), time(m)); };
  std::vector<bool> paired(b.modes.size(), false);
  for (const ModePair& p : pair_modes(a, b)) {
    md += "| " + cells(a.modes[p.a]) + " | ";
    md += p.b ? cells(b.modes[*p.b]) : std::string("— | — | —");
    const bool type_changes = p.b && a.modes[p.a].conjugate_pair != b.modes[*p.b].conjugate_pair;
    md += " | " + similarity_str(p) + (type_changes ? " (root type changes)" : "") + " |\n";
    if (p.b) paired[*p.b] = true;
  }
  for (std::size_t j = 0; j < b.modes.size(); ++j)
    if (!paired[j]) md += "| — | — | — | " + cells(b.modes[j]) + " | — |\n";
  return md;
}

std::string figure_md(const std::string& name, const std::string& caption, const ReportFiles& f) {
  if (!f.figures.count(name)) return "";
  return fmt::format("![{}]({})\n\n*{}*\n\n", caption, name, caption);
}

void add_figures(const ReportInputs& in, ReportFiles& out) {
  std::string why;
  auto keep = [&](const std::string& name, std::optional<std::string> svg) {
    if (svg) out.figures[name] = *svg;
    else if (out.figure_notice.empty()) out.figure_notice = why;
  };
  // Loads over the trimmed wingbeat, normalised by the weight (and weight x wing length).
  const Case& c = *in.case_file;
  const double W = c.insect.weight(), R = c.insect.wing.length, T = in.trim->kinematics.period();
  LinePlot loads{"Loads over the trimmed wingbeat (stability axes, about the mean CoM)", "t / T",
                 "force / weight, moment / (weight R)", {}, false, true};
  Series fx{"X / W", {}, {}}, fz{"-Z / W (vertical force)", {}, {}}, my{"M / (W R)", {}, {}};
  for (const auto& s : in.history->samples) {
    const Wrench w = s.total();
    fx.x.push_back(s.time / T), fx.y.push_back(w.force.x() / W);
    fz.x.push_back(s.time / T), fz.y.push_back(-w.force.z() / W);
    my.x.push_back(s.time / T), my.y.push_back(w.moment.y() / (W * R));
  }
  loads.series = {fx, fz, my};
  keep("figures/loads.svg", render_svg(loads, why));
  // Eigenvalues on the complex plane (non-dimensional), one series per analysis.
  // Each root labelled with its mode's name (at the Im >= 0 member of a pair).
  LinePlot eig{"Eigenvalues (non-dimensional, per unit tU/c)", "Re λ⁺", "Im λ⁺", {}, true, true};
  for (const auto* a : {&in.stability->longitudinal, &in.stability->lateral}) {
    if (!*a) continue;
    Series s{(*a)->name, {}, {}};
    for (const auto& m : (*a)->modes) {
      s.x.push_back(m.eigenvalue_nd.real());
      s.y.push_back(m.eigenvalue_nd.imag());
      eig.labels.push_back({m.eigenvalue_nd.real(), m.eigenvalue_nd.imag(), m.name});
      if (m.conjugate_pair) {
        s.x.push_back(m.eigenvalue_nd.real());
        s.y.push_back(-m.eigenvalue_nd.imag());
      }
    }
    eig.series.push_back(s);
  }
  stagger_axis_labels(eig.labels, 1e-12);
  keep("figures/eigenvalues.svg", render_svg(eig, why));
  if (in.floquet) {
    // Floquet multipliers against the unit circle (|mu| > 1 grows), each mode's multiplier named.
    LinePlot mu{"Floquet multipliers (one wingbeat)", "Re μ", "Im μ", {}, true, true};
    Series circle{"unit circle |μ| = 1", {}, {}, "lines dt 2 lc rgb 'gray'"};
    for (int k = 0; k <= 360; ++k) circle.x.push_back(std::cos(k * deg)), circle.y.push_back(std::sin(k * deg));
    mu.series.push_back(circle);
    for (const FloquetSubsystem* f : {&in.floquet->longitudinal, &in.floquet->lateral}) {
      Series s{f->phase_resolved.name, {}, {}};
      for (const auto& z : f->phase_resolved.multipliers) s.x.push_back(z.real()), s.y.push_back(z.imag());
      for (const auto& m : f->phase_resolved.modes.modes) {
        const std::complex<double> z = std::exp(m.eigenvalue_per_wingbeat);
        mu.labels.push_back({z.real(), z.imag(), m.name});
      }
      mu.series.push_back(s);
    }
    mu.equal_axes = true;
    stagger_axis_labels(mu.labels, 1e-9);
    keep("figures/floquet_multipliers.svg", render_svg(mu, why));
    // The body's rocking over the wingbeat on the periodic orbit: deviations from the cycle means.
    const PhaseDerivatives& ph = in.floquet->phase;
    if (!ph.samples.empty()) {
      const double period = in.floquet->cyclic.period;
      double mx = 0, mz = 0, mt = 0;
      for (const auto& smp : ph.samples) mx += smp.state(0), mz += smp.state(2), mt += smp.state(10);
      const double n = double(ph.samples.size());
      mx /= n, mz /= n, mt /= n;
      LinePlot orbit{"Body motion over the wingbeat on the periodic hover orbit (deviation from the cycle mean)", "t / T",
                     "pitch θ (deg)", {}, false, false};
      orbit.y2label = "position (mm)";
      Series th{"pitch θ (deg, left axis)", {}, {}}, x{"x, forward (mm, right axis)", {}, {}},
          z{"z, down (mm, right axis)", {}, {}};
      x.right_axis = z.right_axis = true;
      for (std::size_t k = 0; k <= ph.samples.size(); ++k) {  // closed: the orbit's first state again at t = T
        const auto& smp = ph.samples[k % ph.samples.size()];
        const double tau = k < ph.samples.size() ? smp.time / period : 1.0;
        th.x.push_back(tau), th.y.push_back((smp.state(10) - mt) / deg);
        x.x.push_back(tau), x.y.push_back((smp.state(0) - mx) * 1e3);
        z.x.push_back(tau), z.y.push_back((smp.state(2) - mz) * 1e3);
      }
      orbit.series = {th, x, z};
      keep("figures/body_oscillation.svg", render_svg(orbit, why));
    }
  }
  // Mode shapes: eigenvector magnitudes (attitude-normalised) and phases per state.
  for (const auto* a : {&in.stability->longitudinal, &in.stability->lateral}) {
    if (!*a) continue;
    BarPlot mag{fmt::format("{} mode shapes: |eigenvector| (attitude component = 1)", (*a)->name), "magnitude",
                (*a)->state_order, {}};
    BarPlot ph{fmt::format("{} mode shapes: phase relative to the attitude (deg)", (*a)->name), "phase (deg)",
               (*a)->state_order, {}, -180, 180};
    for (const auto& m : (*a)->modes) {
      BarGroup gm{m.name, {}}, gp{m.name, {}};
      for (const auto& v : m.eigenvector) {
        gm.values.push_back(std::abs(v));
        gp.values.push_back(std::abs(v) > 1e-9 ? std::arg(v) / deg : 0.0);
      }
      mag.groups.push_back(gm);
      ph.groups.push_back(gp);
    }
    keep(fmt::format("figures/modes_{}_magnitude.svg", (*a)->name), render_svg(mag, why));
    keep(fmt::format("figures/modes_{}_phase.svg", (*a)->name), render_svg(ph, why));
  }
}

// One statement: is the hover stable, which modes grow and how fast, by which model, and what the case's
// feedback does.
std::string verdict(const ReportInputs& in) {
  std::vector<std::string> growing;
  double fastest = INFINITY;
  for (const auto* a : {&in.stability->longitudinal, &in.stability->lateral}) {
    if (!*a) continue;
    for (const auto& m : (*a)->modes)
      if (m.eigenvalue_nd.real() > 0) {
        growing.push_back(fmt::format("{} {}", (*a)->name, m.name));
        if (m.time_to_double_wingbeats) fastest = std::min(fastest, *m.time_to_double_wingbeats);
      }
  }
  std::string v;
  if (growing.empty()) v = "the hover is stable in the averaged model";
  else
    v = fmt::format("the hover is unstable in the averaged model ({}; the fastest doubles in {:.3g} wingbeats)",
                    fmt::join(growing, ", "), fastest);
  if (in.floquet) {
    double lon = 0, lat = 0;
    for (const auto& m : in.floquet->longitudinal.phase_resolved.multipliers) lon = std::max(lon, std::abs(m));
    for (const auto& m : in.floquet->lateral.phase_resolved.multipliers) lat = std::max(lat, std::abs(m));
    v += fmt::format("; the time-periodic (Floquet) model {} (largest |mu| {:.4f} longitudinal, {:.4f} lateral)",
                     (lon > 1 || lat > 1) == !growing.empty() ? "agrees" : "disagrees", lon, lat);
    // Which model to trust: where the averaged and periodic growth per wingbeat differ by more than 10 %, the
    // periodic one, which keeps the body's within-wingbeat oscillation (Wu & Sun 2012, J R Soc Interface 9:2033:
    // Floquet agrees with coupled Navier-Stokes simulation for the hawkmoth, the averaged model does not).
    std::vector<std::string> differ;
    auto lti_growth = [](const std::optional<StabilityAnalysis>& a) {
      double g = -INFINITY;
      if (a)
        for (const auto& m : a->modes) g = std::max(g, m.eigenvalue_per_wingbeat.real());
      return g;
    };
    const double gl = lti_growth(in.stability->longitudinal), gt = lti_growth(in.stability->lateral);
    if (std::isfinite(gl) && std::abs(std::log(lon) - gl) > 0.1 * std::max(std::abs(gl), 1e-3))
      differ.push_back(fmt::format("longitudinal {:+.3f} vs {:+.3f}", std::log(lon), gl));
    if (std::isfinite(gt) && std::abs(std::log(lat) - gt) > 0.1 * std::max(std::abs(gt), 1e-3))
      differ.push_back(fmt::format("lateral {:+.3f} vs {:+.3f}", std::log(lat), gt));
    if (!differ.empty())
      v += fmt::format("; the growth per wingbeat differs by more than 10 % ({}, periodic vs averaged): trust the "
                       "periodic model, which keeps the body's rocking within the wingbeat",
                       fmt::join(differ, ", "));
  }
  if (in.control) {
    const ControlSummary& k = *in.control;
    const bool a = k.closed_abscissa < 0, p = k.closed_radius < 1;
    v += fmt::format("; the case's pitch feedback ({} deg/deg, {} s, {:.0f} ms) {} the longitudinal hover ({}{})",
                     in.case_file->control.pitch_gain, in.case_file->control.rate_gain_s,
                     in.case_file->control.pitch_latency_s * 1e3, a && p ? "stabilises" : (a || p ? "stabilises, in one model only," : "does not stabilise"),
                     a ? "averaged stable" : "averaged unstable", p ? ", periodic stable" : ", periodic unstable");
    if (std::isfinite(k.critical.latency))
      v += fmt::format(" up to a latency of {:.1f} ms ({:.2f} wingbeats)", k.critical.latency * 1e3, k.critical.latency / k.period);
    v += "; it does not act on the lateral modes";
  }
  return v + ".";
}

}  // namespace

std::string report_verdict(const ReportInputs& in) {
  if (in.trim && !in.trim->solved)
    return fmt::format("NOT TRIMMED (--no-trim; residual force {:.3g} x weight, moment {:.3g} x weight x R): {}",
                       in.trim->relative_force_residual, in.trim->relative_moment_residual, verdict(in));
  return verdict(in);
}

ReportFiles build_report(const ReportInputs& in) {
  ReportFiles out;
  add_figures(in, out);
  const Case& c = *in.case_file;
  const TrimResult& t = *in.trim;
  const DerivativeTable& d = in.derivatives->table;
  std::ostringstream md;
  md << fmt::format("# Hover stability of {}\n\n", c.insect.name);
  if (!c.description.empty()) md << c.description << "\n\n";
  md << fmt::format(
      "Case file `{}`; aerodynamic model: {}; flapstab {}. Axes: hover stability axes (body-fixed, origin at the "
      "wingbeat-mean centre of mass, x forward and horizontal at trim, y right, z down). SI units unless stated. "
      "Run time {:.2f} s.\n\n",
      c.path, in.derivatives->table.source, FLAPSTAB_VERSION, in.wall_time_s);
  md << "Sources of the insect's numbers:\n\n";
  for (const auto& s : c.sources) md << "- " << s << "\n";
  md << "\n## Summary\n\n";
  md << "**Verdict:** " << report_verdict(in) << "\n\n";
  auto count_unstable = [](const std::optional<StabilityAnalysis>& a) {
    int n = 0;
    if (a)
      for (const auto& m : a->modes) n += m.eigenvalue_nd.real() > 0;
    return n;
  };
  if (in.stability->longitudinal)
    md << fmt::format("- Longitudinal: {} unstable mode(s) of {}.\n", count_unstable(in.stability->longitudinal),
                      in.stability->longitudinal->modes.size());
  if (in.stability->lateral)
    md << fmt::format("- Lateral: {} unstable mode(s) of {}.\n", count_unstable(in.stability->lateral),
                      in.stability->lateral->modes.size());
  for (const auto* a : {&in.stability->longitudinal, &in.stability->lateral}) {
    if (!*a) continue;
    for (const auto& m : (*a)->modes)
      if (m.eigenvalue_nd.real() > 0 && m.time_to_double_s)
        md << fmt::format("- {} {}: doubles in {:.3g} s ({:.3g} wingbeats).\n", (*a)->name, m.name,
                          *m.time_to_double_s, *m.time_to_double_wingbeats);
  }
  md << "\n## Hover trim\n\n";
  if (!t.solved)
    md << fmt::format("**Not trimmed (--no-trim):** everything below is evaluated at the case's kinematics as they "
                      "are. Mean force residual (aerodynamic force + weight) X {:.4g}, Y {:.4g}, Z {:.4g} N; moment "
                      "residual L {:.4g}, M {:.4g}, N {:.4g} N m.\n\n",
                      t.force_residual.x(), t.force_residual.y(), t.force_residual.z(), t.moment_residual.x(),
                      t.moment_residual.y(), t.moment_residual.z());
  md << fmt::format("Solver {} ({}), {} iterations, {} model runs. Residuals: force {:.2e} × weight, moment "
                    "{:.2e} × weight × wing length. Weight {:.4g} N; mean aerodynamic power {:.4g} W ({:.4g} W/kg).\n\n",
                    t.solver, t.objective, t.iterations, t.model_runs, t.relative_force_residual,
                    t.relative_moment_residual, t.weight, t.mean_power, t.mean_power / c.insect.total_mass());
  md << "| parameter | trimmed | initial | lower | upper | unit |\n|---|---|---|---|---|---|\n";
  // The trimmed mid-stroke incidences follow pitch_mean_deg (or end the table): what the pitch parameters mean.
  const auto trimmed_incidence = mid_stroke_incidence(t.kinematics), case_incidence = mid_stroke_incidence(c.kinematics);
  auto incidence_rows = [&] {
    if (!trimmed_incidence) return std::string();
    auto initial = [&](double StrokeIncidence::*half) {
      return case_incidence ? fmt::format("{:.6g}", (*case_incidence).*half / deg) : std::string("—");
    };
    return fmt::format("| incidence at mid-downstroke (t/T = {:.3f}) | {:.6g} | {} | — | — | deg |\n"
                       "| incidence at mid-upstroke (t/T = {:.3f}) | {:.6g} | {} | — | — | deg |\n",
                       trimmed_incidence->downstroke_phase, trimmed_incidence->downstroke / deg,
                       initial(&StrokeIncidence::downstroke), trimmed_incidence->upstroke_phase,
                       trimmed_incidence->upstroke / deg, initial(&StrokeIncidence::upstroke));
  };
  bool incidence_written = false;
  for (const auto& p : t.parameters) {
    md << fmt::format("| {} | {:.6g} | {:.6g} | {:g} | {:g} | {} |\n", p.label, p.value, p.initial, p.lower, p.upper,
                      p.unit);
    if (!incidence_written && p.label.rfind("pitch_mean_deg", 0) == 0) md << incidence_rows(), incidence_written = true;
  }
  if (!incidence_written) md << incidence_rows();
  if (trimmed_incidence)
    md << "\nIncidence: the geometric angle of attack of the right wing, between its chord (towards the leading edge) "
          "and its velocity relative to the body perpendicular to the span (no induced flow), halfway between the "
          "stroke reversals; with no deviation rate there it is the pitch angle α at mid-downstroke and 180° − α at "
          "mid-upstroke.\n";
  md << "\n" << figure_md("figures/loads.svg", "Force and pitching moment over the trimmed wingbeat.", out);
  md << "## Derivatives (non-dimensional)\n\n";
  const ReferenceQuantities& r = d.reference;
  md << fmt::format(
      "Reference: U = 2Φnr₂ = {:.4g} m/s, c = {:.4g} m, S_t = {:.4g} m², ρ = {:.4g} kg/m³, n = {:.4g} Hz. Mass "
      "{:.4g} kg; I_xx {:.4g}, I_yy {:.4g}, I_zz {:.4g}, I_xz {:.4g} kg m² (about the mean CoM). Central "
      "differences with steps {:.3g} m/s and {:.3g} rad/s.\n\n",
      r.U, r.c, r.S_t, r.rho, r.frequency, d.mass.m, d.mass.Ixx, d.mass.Iyy, d.mass.Izz, d.mass.Ixz,
      in.derivatives->velocity_step, in.derivatives->rate_step);
  md << "| | u | v | w | p | q | r |\n|---|---|---|---|---|---|---|\n";
  for (int i = 0; i < 6; ++i) {
    md << "| " << "XYZLMN"[i];
    for (int j = 0; j < 6; ++j) md << fmt::format(" | {:.4g}", d.nd(i, j));
    md << " |\n";
  }
  md << "\n## Stability\n\n" << stability_markdown(*in.stability) << "\n";
  md << figure_md("figures/eigenvalues.svg",
                  "Eigenvalues on the complex plane (non-dimensional), each root named by its mode.", out);
  for (const auto* a : {&in.stability->longitudinal, &in.stability->lateral}) {
    if (!*a) continue;
    md << figure_md(fmt::format("figures/modes_{}_magnitude.svg", (*a)->name),
                    fmt::format("{} mode shapes: eigenvector magnitudes, attitude component = 1.", (*a)->name), out);
    md << figure_md(fmt::format("figures/modes_{}_phase.svg", (*a)->name),
                    fmt::format("{} mode shapes: phases relative to the attitude component (deg).", (*a)->name), out);
  }
  if (in.floquet) {
    const FloquetStudy& f = *in.floquet;
    const CyclicTrimResult& cy = f.cyclic;
    md << "## Time-periodic hover (Floquet)\n\n";
    md << fmt::format(
        "Cyclic trim of the free body-plus-wings system (shooting with CVODES sensitivities): periodicity residual "
        "{:.2e} after {} Newton iterations. Within-cycle oscillation (half peak-to-peak): u {:.3g} m/s, w {:.3g} m/s, "
        "q {:.3g} rad/s, θ {:.3g}°. Monodromy by two routes (phase-resolved derivatives; sensitivities of the "
        "nonlinear flow) agree to {:.1e} (longitudinal) and {:.1e} (lateral) in the multipliers.\n\n",
        cy.residual, cy.iterations, cy.amplitude_si(0), cy.amplitude_si(1), cy.amplitude_si(2),
        cy.amplitude_si(3) / deg, f.longitudinal.max_multiplier_difference, f.lateral.max_multiplier_difference);
    md << fmt::format("Mean attitude over the orbit (body long axis above the horizontal): {:.4f}° ({}).\n\n",
                      cy.mean_body_angle / deg,
                      cy.free_attitude ? "free: the body angle held at the averaged trim's, the orbit's own mean pitch "
                                         "added"
                                       : "imposed: the orbit's mean pitch is the averaged trim's attitude");
    md << "| parameter | cyclic trim | averaged trim | unit |\n|---|---|---|---|\n";
    for (const auto& p : cy.parameters)
      md << fmt::format("| {} | {:.6g} | {:.6g} | {} |\n", p.label, p.value, p.initial, p.unit);
    md << "The \"LTI\" rows below are the averaged model linearised at the cyclic trim's kinematics (the parameters "
          "above), so that both models see the same wingbeat; the Stability section's eigenvalues are at the averaged "
          "trim's kinematics, hence the small differences.\n";
    md << "\n### Longitudinal [u, w, q, θ]\n\n" << floquet_table(f.longitudinal);
    md << "\n### Lateral [v, p, r, φ]\n\n" << floquet_table(f.lateral) << "\n";
    md << "Exponents λ⁺ are per unit t⁺ = tU/c (log μ / T × c/U); a mode grows when |μ| > 1. Each Floquet mode is "
          "beside the averaged mode of the most similar eigenvector (1 = the same shape; docs/theory/modes.md).\n\n";
    md << figure_md("figures/floquet_multipliers.svg",
                    "Floquet multipliers μ (one wingbeat) and the unit circle: a mode outside the circle grows.", out);
    md << figure_md("figures/body_oscillation.svg",
                    "Body pitch and position over one wingbeat on the periodic hover orbit, as deviations from their "
                    "cycle means (t = 0: the start of the downstroke).",
                    out);
  }
  if (in.revolving) {
    const RevolvingComparison& r = *in.revolving;
    md << "## Flapping versus revolving wings\n\n";
    md << fmt::format(
        "The equivalent revolving-wing flyer has the same insect with its wings revolving at the flapping wings' mean "
        "stroke speed and fixed pitch {:.1f}° (the mean of the flapping mid-downstroke and mid-upstroke incidences), "
        "trimmed to the same weight: "
        "{:.4g} revolutions per second, body angle {:.2f}°, stroke plane {:.2f}° (residuals {:.1e}, {:.1e}).\n\n",
        r.trim.kinematics.right.pitch.eval(0).f / deg, r.trim.kinematics.frequency_hz,
        r.trim.kinematics.body_angle / deg, r.trim.kinematics.stroke_plane / deg, r.trim.relative_force_residual,
        r.trim.relative_moment_residual);
    md << "Each flapping mode is beside the revolving flyer's mode of the most similar eigenvector (similarity 1: the "
          "same shape; low values: the flyers have no mode of that shape; \"root type changes\": the same motion is a real "
          "root in one flyer and a complex pair in the other; docs/theory/modes.md).\n\n";
    if (in.stability->longitudinal && r.stability.longitudinal)
      md << "### Longitudinal\n\n" << mode_comparison_table(*in.stability->longitudinal, *r.stability.longitudinal) << "\n";
    if (in.stability->lateral && r.stability.lateral)
      md << "### Lateral\n\n" << mode_comparison_table(*in.stability->lateral, *r.stability.lateral) << "\n";
  }
  if (in.control) {
    const ControlSummary& k = *in.control;
    const double T = k.period;
    auto lat = [&](double tau) {
      if (std::isinf(tau)) return fmt::format("beyond {:.1f} ms (the range scanned)", k.latency_max * 1e3);
      if (std::isnan(tau)) return std::string("none (not stable without delay)");
      return fmt::format("{:.1f} ms ({:.2f} wingbeats)", tau * 1e3, tau / T);
    };
    md << "## Pitch feedback\n\n";
    md << fmt::format(
        "Controller ([control] in the case): {}. It acts on the deviations of pitch angle and pitch rate from the "
        "periodic hover orbit. Longitudinal loop, delay-exact (Chebyshev collocation of the delay system refined by "
        "Newton; periodic loop by semi-discretisation of its monodromy):\n\n",
        k.description);
    md << "| model | open loop | with the controller |\n|---|---|---|\n";
    md << fmt::format("| averaged: spectral abscissa per wingbeat | {:+.4f} | {:+.4f} |\n", k.open_abscissa * T,
                      k.closed_abscissa * T);
    md << fmt::format("| periodic: log of the largest multiplier modulus per wingbeat | {:+.4f} | {:+.4f} |\n\n", std::log(k.open_radius),
                      std::log(k.closed_radius));
    md << fmt::format("Critical latency at the case's gains (both signals delayed alike): {}. Best pitch gain in "
                      "[{:g}, {:g}] with the case's rate gain: {:.4g} deg/deg, critical latency {}.\n\n",
                      lat(k.critical.latency), c.control.map_gain_min, c.control.map_gain_max, k.best.gain,
                      lat(k.best.latency));
    const auto& col = k.control.columns.front();
    md << fmt::format("Control derivatives of {} (per {}, non-dimensional): X {:.4g}, Z {:.4g}, M {:.4g}. Neutral "
                      "axis {:.2f} mm ({:.2f} c) above the centre of mass. The map over (gain, latency) and its "
                      "simulated check points: `flapstab control-map`.\n\n",
                      col.parameter, col.unit, col.nd(0), col.nd(2), col.nd(4), -k.neutral.z_at_com * 1e3,
                      -k.neutral.z_at_com / d.reference.c);
  }
  md << in.extra_markdown;
  for (const auto& n : in.notices) md << "**Note:** " << n << "\n\n";
  if (!out.figure_notice.empty()) md << "**Figures omitted:** " << out.figure_notice << "\n\n";
  md << "## Files\n\n- `results.json`: everything above, machine-readable (units and conventions inside).\n"
        "- `derivatives.toml`: the derivative table (docs/derivative-table.md), readable by `flapstab stability "
        "--derivatives`.\n- `loads.csv`: the loads over the trimmed cycle.\n";
  out.markdown = md.str();
  out.html = markdown_to_html(out.markdown, out.figures, "flapstab: " + c.insect.name);
  return out;
}

std::string markdown_to_html(const std::string& md, const std::map<std::string, std::string>& figures,
                             const std::string& title) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << html_escape(title)
    << "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}"
       "table{border-collapse:collapse;margin:1em 0;font-size:0.9em}td,th{border:1px solid #bbb;padding:3px 7px;"
       "text-align:right}th{background:#eee}td:first-child{text-align:left}figure{margin:1em 0}"
       "figcaption{font-style:italic;color:#555}code{background:#f3f3f3;padding:0 3px}svg{max-width:100%;height:auto}"
       "</style></head><body>\n";
  std::istringstream in(md);
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line)) lines.push_back(line);
  bool in_list = false;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string& l = lines[i];
    if (in_list && l.rfind("- ", 0) != 0) {
      h << "</ul>\n";
      in_list = false;
    }
    if (l.empty()) continue;
    if (l[0] == '#') {
      std::size_t n = l.find_first_not_of('#');
      h << fmt::format("<h{0}>{1}</h{0}>\n", n, inline_html(l.substr(n + 1)));
    } else if (l.rfind("- ", 0) == 0) {
      if (!in_list) h << "<ul>\n";
      in_list = true;
      h << "<li>" << inline_html(l.substr(2)) << "</li>\n";
    } else if (l[0] == '|') {
      h << "<table>\n<tr>";
      for (const auto& cell : table_cells(l)) h << "<th>" << inline_html(cell) << "</th>";
      h << "</tr>\n";
      i += 1;  // the |---| separator
      while (i + 1 < lines.size() && !lines[i + 1].empty() && lines[i + 1][0] == '|') {
        ++i;
        h << "<tr>";
        for (const auto& cell : table_cells(lines[i])) h << "<td>" << inline_html(cell) << "</td>";
        h << "</tr>\n";
      }
      h << "</table>\n";
    } else if (l.rfind("![", 0) == 0) {
      const std::size_t a = l.find("]("), b = l.rfind(')');
      const std::string caption = l.substr(2, a - 2), file = l.substr(a + 2, b - a - 2);
      auto it = figures.find(file);
      h << "<figure>" << (it != figures.end() ? it->second.substr(std::min(it->second.find("<svg"), it->second.size()))
                                              : std::string("[missing figure]"))
        << "<figcaption>" << html_escape(caption) << "</figcaption></figure>\n";
      if (i + 2 < lines.size() && lines[i + 1].empty() && lines[i + 2].rfind("*", 0) == 0) i += 2;  // caption line
    } else {
      h << "<p>" << inline_html(l) << "</p>\n";
    }
  }
  if (in_list) h << "</ul>\n";
  h << "</body></html>\n";
  return h.str();
}

}  // namespace flapstab
