#include "apps/validate_command.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <sstream>

#include "apps/plots.hpp"
#include "cfd/navier_stokes/hovering_2d.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "core/interrupt.hpp"

namespace flapstab {

namespace {

namespace fs = std::filesystem;
constexpr const char* kCase = "wbd2004-hovering-2d";

// The shipped reference data: next to an installed program (PREFIX/bin -> PREFIX/share/flapstab), else the source
// tree this program was built from.
std::string default_reference_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "flapstab" / "reference" / kCase;
    if (fs::is_directory(installed)) return installed.string();
  }
  return std::string(FLAPSTAB_DATA_DIR) + "/reference/" + kCase;
}

struct Reference {
  const char* key;    // summary.json key
  const char* title;  // figure legend
  const char* lift_file;
  const char* drag_file;
};
constexpr Reference kReferences[] = {
    {"wang2004_experiment", "Wang, Birch & Dickinson 2004 (measured)", "CL_Wang2004_experiment.dat", "CD_Wang2004_experiment.dat"},
    {"eldredge2007", "Eldredge 2007 (vortex particles)", "CL_Eldredge2007.dat", "CD_Eldredge2007.dat"},
    {"li2015", "Li, Dong & Liu 2015 (immersed boundary)", "CL_Li2015.dat", "CD_Li2015.dat"},
};
constexpr double kReversalGap = 0.02;  // periods left out around each reversal in the drag comparison

nlohmann::json comparison_json(const ns::HistoryComparison& c) {
  return {{"mean_cycles_2_4", c.mean}, {"reference_mean_cycles_2_4", c.reference_mean},
          {"relative_difference", c.mean / c.reference_mean - 1}, {"correlation", c.correlation},
          {"rms_difference", c.rms_difference}, {"points", c.points}};
}

std::string history_csv(const ns::Hovering2dResult& r) {
  std::ostringstream s;
  s << "t,t_over_T,x_centre_c,alpha_deg,lift_per_span,drag_per_span,C_L,C_D,lift_per_span_surface,"
       "drag_per_span_surface,cfl\n";
  s << "0,0," << fmt::format("{:.10g},{:.10g}", r.settings.amplitude / 2, 90.0) << ",0,0,0,0,0,0,0\n";
  for (const auto& x : r.samples)
    s << fmt::format("{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.4g}\n", x.t,
                     x.phase, x.x, x.alpha / deg, x.lift, x.drag, x.cl, x.cd, x.lift_surface, x.drag_surface, x.cfl);
  return s.str();
}

}  // namespace

int run_validate_hovering_2d(const ValidateCommandOptions& o) {
  ns::Hovering2dCase c;
  c.cells_per_chord = o.cells_per_chord;
  c.cycles = o.cycles;
  c.span_cells = o.span_cells;
  try {
    c.check();
  } catch (const std::invalid_argument& e) {
    throw InputError("command line", "hovering-2d", e.what());
  }
  // Read the references first: a missing or broken file stops before the run.
  const std::string dir = o.reference_dir.empty() ? default_reference_dir() : o.reference_dir;
  std::vector<ns::CoefficientHistory> lift, drag;
  for (const Reference& ref : kReferences) {
    lift.push_back(ns::read_coefficient_history(dir + "/" + ref.lift_file, ref.title));
    drag.push_back(ns::read_coefficient_history(dir + "/" + ref.drag_file, ref.title));
  }
  const bool compare = c.cycles >= 4;
  if (!o.quiet)
    fmt::print(stderr,
               "flapstab validate hovering-2d: Wang, Birch & Dickinson 2004 2-D hovering wing, Re {:g}, c/{:g} fine box, "
               "{} span cells, {:g} cycles{}\n",
               c.reynolds, c.cells_per_chord, c.span_cells, c.cycles,
               compare ? "" : " (fewer than 4: no comparison with the published cycles 2-4)");
  InterruptGuard guard;
  const auto t0 = std::chrono::steady_clock::now();
  double next = 0.1;
  const ns::Hovering2dResult r = ns::run_hovering_2d(c, [&](const ns::Hovering2dSample& s) {
    if (const int sig = interrupt_requested())
      throw Interrupted(sig, fmt::format("stopped by {} at t/T = {:.3f}; nothing written (the run is not resumable: "
                                         "run it again)", signal_name(sig), s.phase));
    if (o.quiet || s.phase < next) return;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    fmt::print(stderr, "  t/T {:5.2f}  C_L {:+.3f}  C_D {:+.3f}  CFL {:.2f}  {:.0f} s, about {:.0f} s left\n", s.phase,
               s.cl, s.cd, s.cfl, el, el * (c.cycles / s.phase - 1));
    next += 0.1;
  });

  nlohmann::json j;
  j["case"] = {{"name", "2-D hovering wing, Wang, Birch & Dickinson 2004 (J Exp Biol 207:449)"},
               {"chord", 1.0}, {"thickness_over_chord", c.thickness}, {"stroke_amplitude_A0", c.amplitude},
               {"frequency", c.frequency}, {"pitch_amplitude_deg", c.pitch_amplitude / deg},
               {"reynolds", c.reynolds}, {"max_speed", c.max_speed()}, {"viscosity", c.viscosity()},
               {"cycles", c.cycles}};
  j["grid"] = {{"cells_per_chord", c.cells_per_chord}, {"stretch_ratio", c.stretch_ratio}, {"half_width", c.half_width},
               {"fine_box_x", c.box_x}, {"fine_box_y", c.box_y}, {"span_cells", c.span_cells},
               {"cells", {r.nx, r.ny, r.nz}}, {"steps", r.steps}, {"cfl", c.cfl}, {"wall_time_s", r.seconds},
               {"spanwise_deviation_over_U_max", r.spanwise_deviation}};
  j["normalisation"] = {{"lift_max_per_span", r.normalisation.lift}, {"drag_max_per_span", r.normalisation.drag},
                        {"chord_points", r.normalisation.chord_points},
                        {"rule", "maxima over chord points and a cycle of the quasi-steady force 1/2 |v|^2 C c, "
                                 "C_L = 1.2 sin 2 alpha_e, C_D = 1.4 - cos 2 alpha_e"}};
  {
    // The same means under the other convention found with these reference curves (cuIBM's): 1/2 U_max^2 c x 1.2, x 1.4.
    const double fl = r.normalisation.lift / r.normalisation.lift_translational,
                 fd = r.normalisation.drag / r.normalisation.drag_translational;
    std::vector<double> l, d;
    for (double v : r.cycle_cl) l.push_back(v * fl);
    for (double v : r.cycle_cd) d.push_back(v * fd);
    j["normalisation"]["translational"] = {
        {"lift_per_span", r.normalisation.lift_translational}, {"drag_per_span", r.normalisation.drag_translational},
        {"rule", "1/2 U_max^2 c x 1.2 (lift), x 1.4 (drag): the centre's translation at mid-stroke (barbagroup's cuIBM "
                 "normalises this case so); the reference curves do not say which rule they carry"},
        {"cycle_means", {{"C_L", l}, {"C_D", d}}}};
  }
  j["cycle_means"] = {{"C_L", r.cycle_cl}, {"C_D", r.cycle_cd}, {"C_L_surface_integral", r.cycle_cl_surface},
                      {"C_D_surface_integral", r.cycle_cd_surface}};
  j["axes"] = "x horizontal (stroke), y vertical (up), z span (periodic); lift = +y force, drag = x force against "
              "the translation; loads per unit span from the momentum exchange of the forcing";
  std::vector<double> tau{0.0}, cl{0.0}, cd{0.0};
  for (const auto& s : r.samples) tau.push_back(s.phase), cl.push_back(s.cl), cd.push_back(s.cd);
  std::string verdict = "fewer than 4 cycles: not compared";
  if (compare) {
    nlohmann::json cmp;
    std::vector<ns::HistoryComparison> lc;
    for (std::size_t i = 0; i < lift.size(); ++i) {
      lc.push_back(ns::compare_history(tau, cl, lift[i], 1, 4));
      cmp[kReferences[i].key] = {{"C_L", comparison_json(lc.back())},
                                 {"C_D", comparison_json(ns::compare_history(tau, cd, drag[i], 1, 4, kReversalGap))}};
    }
    j["comparison"] = cmp;
    j["comparison_note"] = fmt::format("means of the cycle means of cycles 2-4; correlation and rms at the reference's "
                                       "points, drag without the points within {} T of a reversal", kReversalGap);
    // The targets (docs/validation.md): mean C_L of cycles 2-4 within 5 % of the CFD pair and within 15 % of the
    // measurement.
    const double lo = std::min(lc[1].reference_mean, lc[2].reference_mean), hi = std::max(lc[1].reference_mean, lc[2].reference_mean);
    const double m = lc[0].mean;
    const bool cfd_ok = m >= 0.95 * lo && m <= 1.05 * hi, exp_ok = std::abs(m / lc[0].reference_mean - 1) <= 0.15;
    j["targets"] = {{"mean_C_L_cycles_2_4", m}, {"cfd_pair", {lo, hi}}, {"within_5_percent_of_cfd_pair", cfd_ok},
                    {"experiment", lc[0].reference_mean}, {"within_15_percent_of_experiment", exp_ok}};
    verdict = fmt::format("mean C_L of cycles 2-4 {:.3f}: {} 5 % of the CFD pair ({:.3f}-{:.3f}), {} 15 % of the "
                          "measurement ({:.3f}, {:+.1f} %)",
                          m, cfd_ok ? "within" : "NOT within", lo, hi, exp_ok ? "within" : "NOT within",
                          lc[0].reference_mean, 100 * (m / lc[0].reference_mean - 1));
  }
  j["verdict"] = verdict;

  std::vector<std::pair<std::string, std::string>> files = {{o.output_dir + "/history.csv", history_csv(r)},
                                                            {o.output_dir + "/summary.json", j.dump(2) + "\n"}};
  std::string why;
  for (int which = 0; which < 2; ++which) {
    LinePlot p;
    p.title = fmt::format("2-D hovering wing, Re 75: {} (flapstab c/{:g})", which == 0 ? "lift" : "drag", c.cells_per_chord);
    p.xlabel = "t / T";
    p.ylabel = which == 0 ? "C_L = lift / L_max,qs" : "C_D = drag / D_max,qs";
    p.zero_axes = true;
    p.series.push_back(Series{"flapstab", tau, which == 0 ? cl : cd, "lines"});
    const auto& refs = which == 0 ? lift : drag;
    const char* styles[] = {"points pt 6 ps 0.6", "lines dt 2", "lines dt 3"};
    for (std::size_t i = 0; i < refs.size(); ++i) p.series.push_back(Series{refs[i].label, refs[i].phase, refs[i].value, styles[i]});
    if (const auto svg = render_svg(p, why))
      files.emplace_back(o.output_dir + (which == 0 ? "/lift.svg" : "/drag.svg"), *svg);
    else if (!o.quiet)
      fmt::print(stderr, "flapstab validate: no figures: {}\n", why);
  }
  write_files_atomic(files);
  if (!o.quiet) {
    fmt::print("2-D hovering wing (Wang, Birch & Dickinson 2004), c/{:g}: {} x {} x {} cells, {} steps, {:.0f} s\n",
               c.cells_per_chord, r.nx, r.ny, r.nz, r.steps, r.seconds);
    fmt::print("  quasi-steady maxima: L_max {:.4f}, D_max {:.4f} per unit span (translational: {:.4f}, {:.4f})\n",
               r.normalisation.lift, r.normalisation.drag, r.normalisation.lift_translational,
               r.normalisation.drag_translational);
    const double fl = r.normalisation.lift / r.normalisation.lift_translational,
                 fd = r.normalisation.drag / r.normalisation.drag_translational;
    for (std::size_t k = 0; k < r.cycle_cl.size(); ++k)
      fmt::print("  cycle {}: C_L {:.3f}  C_D {:.3f}  (translational normalisation: C_L {:.3f}  C_D {:.3f})\n", k + 1,
                 r.cycle_cl[k], r.cycle_cd[k], r.cycle_cl[k] * fl, r.cycle_cd[k] * fd);
    fmt::print("  {}\n  files: {}/history.csv, summary.json, lift.svg, drag.svg\n", verdict, o.output_dir);
  }
  return 0;
}

}  // namespace flapstab
