// The flapstab command: parses arguments and dispatches to the subcommands in apps/commands.
#include <CLI/CLI.hpp>
#include <cmath>
#include <new>
#include <fmt/format.h>

#include "apps/cfd_command.hpp"
#include "apps/commands.hpp"
#include "apps/floquet_command.hpp"
#include "apps/grid_convergence_command.hpp"
#include "apps/flight_command.hpp"
#include "apps/validate_command.hpp"
#include "core/errors.hpp"

namespace {

// CLI11's Range lets "nan" through (every comparison with it is false): a real-valued option also checks this.
const CLI::Validator finite_number(
    [](std::string& text) {
      double v = 0;
      const bool ok = CLI::detail::lexical_cast(text, v) && std::isfinite(v);
      return ok ? std::string() : "Value " + text + " is not a finite number";
    },
    "FINITE");

void add_common(CLI::App* sub, flapstab::CommandOptions& o) {
  sub->add_option("case", o.case_path, "case file (TOML); see docs/case-file.md")->required()->check(CLI::ExistingFile);
  sub->add_option("--json", o.json_path, "write the machine-readable results to this JSON file");
  sub->add_option("-o,--output", o.output_dir, "write all outputs into this directory");
  sub->add_flag("-q,--quiet", o.quiet, "print nothing on success");
}

// --no-trim on the commands that otherwise trim first.
void add_no_trim(CLI::App* sub, flapstab::CommandOptions& o) {
  sub->add_flag("--no-trim", o.no_trim,
                "do not trim: evaluate at the case's kinematics as they are and report the force and moment residual "
                "(quasi-steady model only)");
}

// --ranks-per-flow on the commands that run the CFD model's flows.
void add_ranks_per_flow(CLI::App* sub, flapstab::CommandOptions& o) {
  sub->add_option("--ranks-per-flow", o.ranks_per_flow,
                  "with model = \"cfd\", under mpiexec -n N: run each CFD flow over K ranks (the grid in z slabs), "
                  "the N / K groups sharing the runs as a campaign (N a multiple of K; docs/user-guide.md)")
      ->type_name("K")
      ->check(CLI::Range(1, 1 << 20));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"flapstab: hover trim, aerodynamic derivatives and flight stability of flapping-wing flyers.\n"
               "Axes: hover stability axes (x forward, y right, z down, origin at the wingbeat-mean CoM). Units: SI."};
  app.set_version_flag("--version", std::string("flapstab ") + FLAPSTAB_VERSION);
  app.require_subcommand(1);
  flapstab::CommandOptions o;
  CLI::App* trim = app.add_subcommand("trim-hover", "cycle-averaged hover trim: kinematic parameters and attitude "
                                                    "at which the mean force balances the weight and the mean moments vanish");
  add_common(trim, o);
  add_ranks_per_flow(trim, o);
  CLI::App* der = app.add_subcommand("derivatives", "trim, then the cycle-averaged stability derivatives "
                                                    "(central differences in u, v, w, p, q, r)");
  add_common(der, o);
  add_no_trim(der, o);
  add_ranks_per_flow(der, o);
  CLI::App* floq = app.add_subcommand("floquet", "time-periodic hover: cyclic trim of the free body-plus-wings "
                                                 "system, phase-resolved derivatives, monodromy by two routes, Floquet "
                                                 "multipliers and modes beside the averaged LTI modes");
  add_common(floq, o);
  add_no_trim(floq, o);
  CLI::App* stab = app.add_subcommand("stability", "eigen-analysis of the hover: longitudinal [u w q theta], lateral "
                                                   "[v p r phi] and coupled 6DoF modes, from a case (trimmed first) "
                                                   "or a derivative table");
  stab->add_option("case", o.case_path, "case file (TOML); or give --derivatives")->check(CLI::ExistingFile);
  stab->add_option("--derivatives", o.derivatives_path, "derivative table (TOML, docs/derivative-table.md)")
      ->check(CLI::ExistingFile);
  stab->add_option("--model", o.model, "longitudinal | lateral | 6dof (all three; default)")
      ->check(CLI::IsMember({"longitudinal", "lateral", "6dof"}));
  stab->add_option("--json", o.json_path, "write the machine-readable results to this JSON file");
  stab->add_option("-o,--output", o.output_dir, "write stability.json and stability.md into this directory");
  stab->add_flag("-q,--quiet", o.quiet, "print nothing on success");
  add_no_trim(stab, o);
  add_ranks_per_flow(stab, o);
  CLI::App* an = app.add_subcommand("analyze", "the main job: trim, derivatives, stability, and a report "
                                               "(report.md, report.html, results.json, derivatives.toml, figures)");
  an->add_option("case", o.case_path, "case file (TOML)")->required()->check(CLI::ExistingFile);
  an->add_option("-o,--output", o.output_dir, "output directory (default: the case's [output] directory)");
  an->add_flag("-q,--quiet", o.quiet, "print nothing on success");
  add_no_trim(an, o);
  add_ranks_per_flow(an, o);
  flapstab::CfdCommandOptions co;
  CLI::App* cfd = app.add_subcommand(
      "cfd", "Navier-Stokes immersed-boundary run of the case's insect ([aero.cfd] settings): prints the grid, memory "
             "and a time estimate, then writes forces.csv, run.json, fields/, surfaces/ and checkpoints/ into DIR "
             "(docs/cfd-files.md); ends with the mean loads of the last complete wingbeat (the start-up wingbeat excluded) "
             "and forces.svg. Ctrl-C or SIGTERM stops at the end of the step with a checkpoint (exit 130 / 143). "
             "Exit status 2 for bad input (nothing written), 3 if the run diverges (the last "
             "checkpoint is kept). Under `mpiexec -n N` the flow runs over N ranks (the grid in z slabs) and "
             "rank 0 writes the same files (docs/user-guide.md)");
  cfd->add_option("case", co.case_path, "case file (TOML) with an [aero.cfd] table; see docs/case-file.md")
      ->required()->check(CLI::ExistingFile);
  cfd->add_option("-o,--output", co.output_dir, "output directory (default: the case's [output] directory)");
  cfd->add_flag("--restart", co.restart, "resume from the newest valid checkpoint in the output directory (refused if "
                                         "the case file changed); reproduces the uninterrupted run exactly");
  cfd->add_option("--cycles", co.cycles, "wingbeats to run in all (overrides [aero.cfd] cycles)")
      ->check(CLI::Range(1, 100000));
  cfd->add_option("--steps", co.steps, "run at most N time steps now (a smoke run shorter than a wingbeat), then write "
                                       "a checkpoint, forces.csv and run.json with status \"stopped\"; --restart continues")
      ->check(CLI::Range(1L, 100000000L));
  cfd->add_flag("--dry-run", co.dry_run, "build the grid, run the checks, time two steps and print the estimate; "
                                         "write nothing");
  cfd->add_flag("-q,--quiet", co.quiet, "no estimate or progress lines");
  flapstab::FlightCommandOptions fo;
  CLI::App* fly = app.add_subcommand(
      "fly", "nonlinear free flight of the trimmed insect from its periodic hover orbit (or from rest) with the "
             "[flight] perturbation and the [control] feedback law: trajectory.csv, run.json, response.svg in DIR. "
             "With [aero] model = \"cfd\": coupled to the Navier-Stokes solver (open or closed loop) from the kept CFD hover, "
             "also steps.csv, fields, surfaces and a checkpoint per wingbeat (the same command resumes; a larger "
             "--wingbeats extends); under `mpiexec -n N` every flow runs over the N ranks (the grid in z slabs)");
  fly->add_option("case", fo.case_path, "case file (TOML) with [flight] and optional [control] tables")
      ->required()->check(CLI::ExistingFile);
  fly->add_option("-o,--output", fo.output_dir, "output directory (default: the case's [output] directory)");
  fly->add_option("--dof", fo.dof, "degrees of freedom: 6dof | longitudinal | pitch | translation (overrides [flight] dof)")
      ->check(CLI::IsMember({"6dof", "longitudinal", "pitch", "translation"}));
  fly->add_option("--wingbeats", fo.wingbeats, "duration in wingbeats (overrides [flight] wingbeats)")
      ->check(finite_number)->check(CLI::Range(1e-3, 1e5));
  fly->add_flag("-q,--quiet", fo.quiet, "print nothing on success");
  CLI::App* cmap = app.add_subcommand(
      "control-map", "delay-exact stability map of the [control.pitch] feedback over (gain, latency): spectral abscissa "
                     "of the averaged loop, the critical latency per gain, the best gain, the periodic (Floquet) loop "
                     "at the best gain, simulated check points; control_map.json, control_map.csv, control_map.svg");
  cmap->add_option("case", fo.case_path, "case file (TOML) with [control] type = \"pitch\" and [control.pitch], [control.map]")
      ->required()->check(CLI::ExistingFile);
  cmap->add_option("-o,--output", fo.output_dir, "output directory (default: the case's [output] directory)");
  cmap->add_flag("--com-sweep", fo.com_sweep, "also move the centre of mass from -c to +c below the wing hinges "
                                             "(nine points, re-trimmed) and compare averaged, Floquet and simulated "
                                             "open-loop pitch growth with the CoM's distance below the neutral axis");
  cmap->add_flag("-q,--quiet", fo.quiet, "print nothing on success");
  flapstab::ValidateCommandOptions vo;
  CLI::App* val = app.add_subcommand("validate", "published validation cases, each run and compared with the published "
                                                 "numbers (docs/validation.md)");
  val->require_subcommand(1);
  CLI::App* h2d = val->add_subcommand(
      "hovering-2d", "the 2-D hovering wing of Wang, Birch & Dickinson 2004 (Re 75, Navier-Stokes): lift and drag "
                     "histories against the robotic-wing measurement and two published CFD results; history.csv, "
                     "summary.json, lift.svg, drag.svg in DIR. About 7 min at the default c/32 on 2 cores");
  h2d->add_option("-o,--output", vo.output_dir, "output directory")->capture_default_str();
  h2d->add_option("--cells-per-chord", vo.cells_per_chord, "grid: cells per chord in the fine box (16 coarse, 32 "
                                                           "default, 48-64 converged)")
      ->check(finite_number)->check(CLI::Range(4.0, 512.0))->capture_default_str();
  h2d->add_option("--cycles", vo.cycles, "periods to run (4 for the comparison with cycles 2-4)")
      ->check(finite_number)->check(CLI::Range(0.01, 100.0))->capture_default_str();
  h2d->add_option("--span-cells", vo.span_cells, "depth of the periodic slab in cells (the flow stays 2-D; "
                                                   "more cells cost proportionally more)")
      ->check(CLI::Range(2, 64))->capture_default_str();
  h2d->add_option("--reference", vo.reference_dir, "directory of the published histories (default: the shipped "
                                                   "reference/wbd2004-hovering-2d)")->check(CLI::ExistingDirectory);
  h2d->add_flag("-q,--quiet", vo.quiet, "print nothing on success");
  flapstab::GridConvergenceOptions go;
  CLI::App* gc = app.add_subcommand(
      "grid-convergence",
      "discretisation error of a CFD derivative table: the same table on two or three grids (results of flapstab "
      "derivatives, stability or analyze with model = \"cfd\"), per derivative the Richardson-extrapolated value, the "
      "order and the grid-convergence index beside the runs' standard errors (docs/theory/cfd-stability.md)");
  gc->add_option("results", go.inputs, "two or three result files (derivatives.json, results.json, stability.json) or "
                                       "the directories holding them, any order")
      ->required()->check(CLI::ExistingPath);
  gc->add_option("--order", go.order, "order assumed with two grids, and where three grids give none (the immersed "
                                      "boundary's near-wall error is first order)")->capture_default_str();
  gc->add_option("-o,--output", go.output_dir, "write grid_convergence.json and grid_convergence.md into this directory");
  gc->add_option("--json", go.json_path, "write the machine-readable results to this JSON file");
  gc->add_flag("-q,--quiet", go.quiet, "print nothing on success");
  app.footer("Exit status: 0 success; 1 unexpected failure; 2 bad input (a missing or unreadable file, an invalid "
             "option or key; the message names the file and key, nothing is written); 3 numerical failure (trim or "
             "cyclic trim not converged, a CFD run diverged; the last CFD checkpoint is kept); 4 an output could not be "
             "written (disk full, read-only or permission denied; the reason is printed, no partial set is left); "
             "130 / 143 stopped by SIGINT / SIGTERM (a CFD run first writes a checkpoint and forces.csv; resume with "
             "--restart).");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Help and version exit 0; every command-line error is bad input (2), as the footer says.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (trim->parsed()) return flapstab::run_in_flow_groups(o, "trim-hover", flapstab::run_trim_hover);
    if (der->parsed()) return flapstab::run_in_flow_groups(o, "derivatives", flapstab::run_derivatives);
    if (an->parsed()) return flapstab::run_in_flow_groups(o, "analyze", flapstab::run_analyze);
    if (cfd->parsed()) return flapstab::run_cfd_command(co);
    if (floq->parsed()) return flapstab::run_floquet(o);
    if (fly->parsed()) return flapstab::run_fly(fo);
    if (cmap->parsed()) return flapstab::run_control_map(fo);
    if (h2d->parsed()) return flapstab::run_validate_hovering_2d(vo);
    if (gc->parsed()) return flapstab::run_grid_convergence(go);
    if (stab->parsed()) {
      if (o.case_path.empty() == o.derivatives_path.empty()) {
        fmt::print(stderr, "flapstab stability: give either a case file or --derivatives TABLE.toml\n");
        return 2;
      }
      return flapstab::run_in_flow_groups(o, "stability", flapstab::run_stability);
    }
  } catch (const flapstab::InputError& e) {
    fmt::print(stderr, "flapstab: error: {}\n", e.what());
    return 2;
  } catch (const flapstab::SolveError& e) {
    fmt::print(stderr, "flapstab: error: {}\n", e.what());
    return 3;
  } catch (const flapstab::OutputError& e) {
    fmt::print(stderr, "flapstab: error: {}\n", e.what());
    return 4;
  } catch (const flapstab::Interrupted& e) {
    fmt::print(stderr, "flapstab: {}\n", e.what());
    return 128 + e.signal();
  } catch (const std::bad_alloc&) {
    fmt::print(stderr, "flapstab: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "flapstab: error: {}\n", e.what());
    return 1;
  }
  return 1;
}
