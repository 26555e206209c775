// The CFD run driver (run.hpp): restart bookkeeping, the estimate, the loop over the Simulation and its observers,
// run.json.
#include "cfd/navier_stokes/run.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <ostream>
#include <sstream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <omp.h>
#include <toml++/toml.h>

#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "cfd/navier_stokes/solver_io.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "core/hash.hpp"
#include "core/interrupt.hpp"

namespace flapstab::ns {

namespace fs = std::filesystem;

std::string case_hash(const std::string& path) {
  try {
    toml::table t = toml::parse_file(path);
    for (const char* k : {"trim", "derivatives", "flight", "control", "output"}) t.erase(k);
    std::ostringstream os;
    os << t;
    return fnv1a64_hex(os.str());
  } catch (const std::exception&) {
    return fnv1a64_file(path);
  }
}

namespace {

void write_run_json(const std::string& path, const Case& c, const std::string& hash, const Simulation& sim,
                    const CfdResult& res) {
  const CfdPlan& plan = res.plan;
  const CfdSettings& s = c.aero.cfd;
  const BodyMotion& motion = sim.motion();
  const Grid& grid = sim.whole_grid();
  nlohmann::json j;
  j["program"] = "flapstab";
  j["version"] = FLAPSTAB_VERSION;
  j["command"] = "cfd";
  j["case"] = c.path;
  j["case_fnv1a64"] = hash;
  j["conventions"] = "hover stability axes S (x forward, y right, z down), origin O = wingbeat-mean centre of mass; "
                     "SI units; loads on the parts, moments about O";
  nlohmann::json g;
  g["cells"] = {grid.axis[0].n, grid.axis[1].n, grid.axis[2].n};
  g["total_cells"] = res.cells;
  g["domain_lo_m"] = {plan.domain_lo.x(), plan.domain_lo.y(), plan.domain_lo.z()};
  g["domain_hi_m"] = {plan.domain_hi.x(), plan.domain_hi.y(), plan.domain_hi.z()};
  g["fine_box_lo_m"] = {plan.fine_lo.x(), plan.fine_lo.y(), plan.fine_lo.z()};
  g["fine_box_hi_m"] = {plan.fine_hi.x(), plan.fine_hi.y(), plan.fine_hi.z()};
  g["fine_spacing_m"] = plan.h_actual;
  g["cells_per_mean_chord"] = plan.chord_cells;
  g["stretch_ratio"] = s.stretch_ratio;
  g["sponge_width_m"] = plan.sponge_width;  // 0: no sponge layer
  g["sponge_rate_per_s"] = plan.sponge_rate;
  g["bytes"] = res.bytes;
  g["bytes_per_cell"] = double(res.bytes) / res.cells;
  j["grid"] = g;
  j["flow"] = {{"reynolds", plan.reynolds}, {"u_ref_m_s", plan.u_ref}, {"l_ref_m", plan.l_ref},
               {"reynolds_definition", "Re = U_ref L_ref / nu, U_ref = 2 Phi f R (mean wingtip speed), L_ref = mean chord"},
               {"kinematic_viscosity_m2_s", plan.nu}, {"density_kg_m3", plan.rho},
               {"body_velocity_m_s", {motion.velocity.x(), motion.velocity.y(), motion.velocity.z()}},
               {"body_rates_rad_s", {motion.rate.x(), motion.rate.y(), motion.rate.z()}}};
  j["time"] = {{"cycles", plan.cycles}, {"period_s", plan.period}, {"steps", res.steps},
               {"steps_per_cycle", plan.steps_per_cycle}, {"dt_s", plan.dt > 0 ? plan.dt : sim.last_dt()},
               {"end_time_s", sim.time()}, {"restarted_from", res.restarted_from},
               {"restart_step", res.start_step}};
  j["timings"] = {{"wall_s", res.wall_seconds},
                  {"seconds_per_step_estimate", res.seconds_per_step_estimate},
                  {"seconds_per_step", res.seconds_per_step},
                  {"ns_per_cell_per_step", 1e9 * res.seconds_per_step / res.cells},
                  {"threads", omp_get_max_threads()},
                  {"ranks", sim.solver().decomposition().size()}};
  j["pressure_solves"] = {{"not_converged", sim.solver().unconverged_pressure_solves()},
                          {"worst_residual_over_tolerance", sim.solver().worst_pressure_residual()},
                          {"note", "solves of this process that stopped at the iteration limit above their tolerance"}};
  // The result: mean loads over the last complete wingbeat, the start-up wingbeat excluded (cfd_run_result).
  const CfdRunResult& r = res.result;
  auto vec = [](const Vec3& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  nlohmann::json result;
  if (r.available) {
    result["wingbeat"] = r.wingbeat;
    result["from_s"] = r.from_s;
    result["to_s"] = r.to_s;
    result["complete_wingbeat"] = r.complete;
    result["includes_startup"] = r.includes_startup;
    result["note"] = r.note;
    result["force_N"] = vec(r.mean.force);
    result["moment_N_m"] = vec(r.mean.moment);
    result["wing_power_W"] = r.wing_power;
    result["weight_N"] = r.weight;
    result["lift_over_weight"] = r.lift_over_weight;
    for (int i = 0; i < r.parts; ++i)
      result["parts"][part_names[i]] = {{"force_N", vec(r.part_mean[i].force)}, {"moment_N_m", vec(r.part_mean[i].moment)}};
  }
  j["status"] = res.status;
  j["result"] = result;
  // The same window under its earlier name (kept for readers of older run.json files).
  nlohmann::json mean;
  if (r.available) {
    for (int i = 0; i <= r.parts; ++i) {
      const Wrench& w = i == r.parts ? r.mean : r.part_mean[i];
      mean[i == r.parts ? "total" : part_names[i]] = {{"force_N", vec(w.force)}, {"moment_N_m", vec(w.moment)}};
    }
    mean["wing_power_W"] = r.wing_power;
    mean["from_s"] = r.from_s;
    mean["to_s"] = r.to_s;
  }
  j["mean_loads_last_cycle"] = mean;
  j["files"]["forces.csv"] = {
      {"rows", "one per time step (step 1 onwards); one header row, units in the column names"},
      {"axes", "hover stability axes S (x forward, y right, z down), body-fixed; origin O = wingbeat-mean centre of "
               "mass; moments about O"},
      {"units", "time s, force N, moment N m, power W; phase = t / T modulo 1"},
      {"columns", std::string("PART_F{x,y,z}_{p,v}_N, PART_M{x,y,z}_{p,v}_N_m, PART_P_W for PART = ") +
                      (r.parts == max_parts ? "body, right, left, hind_right, hind_left" : "body, right, left") +
                      " (p = pressure part, v = viscous part, P = the part's rate of work on the air); F{x,y,z}_N, "
                      "M{x,y,z}_N_m = totals; wing_power_W = the wings' work on the air through their motion "
                      "relative to the body"}};
  if (!res.fpm_means_json.empty()) {
    j["fpm"] = nlohmann::json::parse(res.fpm_means_json);
    j["files"]["fpm.csv"] = {
        {"rows", "one per force-partitioning sample, part and component; one header row"},
        {"axes", "as forces.csv: hover stability axes S, moments about O"},
        {"units", "the row's unit column: N (Fx Fy Fz), N m (Mx My Mz), W (power: the part's work on the air)"},
        {"columns", "pressure = the pressure load on the partition's body (fpm \"body\") that the parts sum to; "
                    "kinematic = added_mass + centripetal "
                    "(acceleration reaction); vortex, viscous, outer; sum = kinematic + vortex + viscous + outer; "
                    "solver_pressure, solver_viscous = the run's loads (forces.csv); pressure_forced = the share of "
                    "pressure on the faces the immersed boundary forces, which no part accounts for (0 for body = "
                    "\"forced-region\"); vortex.REGION = "
                    "the vortex-induced part by region of the flow"}};
  }
  write_file_atomic(path, j.dump(2) + "\n");
}

}  // namespace

void check_ranks_share_grid(const CfdPlan& plan, int ranks, bool bodies, const std::string& file,
                            const std::string& key) {
  if (ranks <= 1) return;
  const Grid g = plan_grid(plan);
  const std::string why = Solver::split_problem(g, ranks, bodies);
  if (why.empty()) return;
  int most = 1;
  for (int r = ranks - 1; r >= 2 && most == 1; --r)
    if (Solver::split_problem(g, r, bodies).empty()) most = r;
  throw InputError(file, key,
                   fmt::format("{} ranks cannot share this grid ({} x {} x {} cells, split along z): {}", ranks,
                               g.axis[0].n, g.axis[1].n, g.axis[2].n, why),
                   most > 1 ? fmt::format("at most {} ranks for this grid, or more z cells (a finer grid, a taller "
                                          "domain)", most)
                            : std::string("one process for this grid, or more z cells (a finer grid, a taller "
                                          "domain)"));
}

CfdResult run_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, const CfdRunOptions& o) {
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  check_cfd_geometry(c.insect, c.path);  // before anything is planned or written (any [aero] model)
  const CfdSettings& s = c.aero.cfd;
  const std::shared_ptr<const Decomposition> dec =
      o.decomposition ? o.decomposition : std::make_shared<const Decomposition>();
  const Decomposition& D = *dec;
  std::ostream* log = D.rank() == 0 ? o.log : nullptr;  // over ranks, rank 0 speaks for all
  CfdResult res;
  res.plan = plan_cfd(c, kin, motion, o.cycles);
  const CfdPlan& plan = res.plan;
  const bool write = !o.directory.empty() && !o.dry_run;  // (only rank 0 of a decomposed run writes the files)
  if (o.restart && o.directory.empty()) throw InputError("", "--restart", "needs an output directory", "-o DIR");
  if (D.distributed() && s.fpm.enabled && o.bodies)
    throw InputError(c.path, "aero.cfd.fpm.enabled",
                     fmt::format("force partitioning does not run over MPI ranks yet (its potentials are solved on one "
                                 "process's grid), and mpiexec started {} ranks",
                                 D.size()),
                     "false, or flapstab cfd in one process");

  // Restart: the newest checkpoint that opens and belongs to this case.
  const std::string ckdir = o.directory + "/checkpoints";
  const std::string hash = c.path.empty() ? std::string("none") : case_hash(c.path);
  const std::string grid_text = grid_summary(plan_grid(plan));
  std::optional<CheckpointReader> ck;
  std::optional<SimulationState> restored;
  if (o.restart) {
    const auto list = checkpoints_in(ckdir);
    std::string why = "none found";
    for (auto it = list.rbegin(); it != list.rend() && !ck; ++it) {
      try {
        ck.emplace(it->second);
        for (const char* name : {"u0", "u1", "u2", "p", "phi0", "phi1", "phi2"})
          if (!ck->contains(name)) throw InputError(it->second, name, "missing array", "a checkpoint of flapstab cfd");
        if (!ck->header().values.count("guess")) throw InputError(it->second, "guess", "missing value", "a checkpoint of flapstab cfd");
        ck->verify();  // every array against its checksum: a damaged checkpoint is skipped for the one before
        res.restarted_from = it->second;
      } catch (const std::exception& e) {
        ck.reset();
        why = e.what();
        if (log) *log << "  skipping " << it->second << ": " << e.what() << "\n";
      }
    }
    if (!ck) throw InputError(ckdir, "--restart", "no readable checkpoint (" + why + ")", "a directory of an earlier run");
    const auto& text = ck->header().text;
    if (!text.count("case_hash") || text.at("case_hash") != hash)
      throw InputError(c.path, "--restart",
                       fmt::format("the case file changed since {} was written (hash {} there, {} now)",
                                   res.restarted_from, text.count("case_hash") ? text.at("case_hash") : "none", hash),
                       "the case file of the interrupted run, unchanged");
    if (!text.count("grid") || text.at("grid") != grid_text)
      throw InputError(c.path, "--restart", "the checkpoint's grid differs from this run's (cycles or body motion changed?)",
                       "the settings of the interrupted run");
    // A finished run: nothing to do, and nothing is rewritten (run.json keeps the record of the run).
    const long ck_step = long(ck->header().step);
    const bool done = plan.steps_per_cycle > 0 ? ck_step >= long(plan.cycles) * plan.steps_per_cycle
                                               : ck->header().time >= plan.cycles * plan.period * (1 - 1e-12);
    if (done) {
      res.status = "nothing to do";
      res.start_step = res.steps = ck_step;
      if (log)
        *log << fmt::format("flapstab cfd: nothing to do: the run in {} is complete ({} wingbeats, step {}, {}); its "
                            "files are unchanged (give --cycles N to run further)\n",
                            o.directory, plan.cycles, ck_step, res.restarted_from);
      return res;
    }
  }

  check_ranks_share_grid(plan, D.size(), o.bodies, c.path, "mpiexec -n");  // before anything is built
  if (s.fpm.enabled && o.bodies) fpm::check_fpm_memory(plan, s.fpm, c.path);  // before anything large is allocated
  SimulationOptions so;
  so.bodies = o.bodies;
  so.initial_velocity = o.initial_velocity;
  so.decomposition = o.decomposition;
  so.pressure_rtol = o.pressure_rtol;
  Simulation sim(c, kin, motion, plan, so);
  if (ck) {
    // Over ranks every rank reads its slab's planes only (the whole file streamed through for its checksums)
    sim.restore(read_state_over_ranks(*ck, sim.whole_grid(), D));
    res.start_step = sim.step();
  }
  const long start_step = sim.step();
  const Grid& grid = sim.whole_grid();
  res.cells = sim.cells();
  res.bytes = std::size_t(D.sum(double(sim.bytes())));  // all ranks' (collective: outside the rank-0-only log below)
  const std::size_t solver_bytes = std::size_t(D.sum(double(sim.solver().bytes())));
  const double largest_rank_bytes = D.max(double(sim.bytes()));
  const double t_end = plan.cycles * plan.period;
  const long total_steps = plan.steps_per_cycle > 0 ? long(plan.cycles) * plan.steps_per_cycle : 0;
  const auto in_run = [&](long k, double t) {
    return plan.steps_per_cycle > 0 ? k < total_steps : t < t_end * (1 - 1e-12);
  };
  if (log) {
    const double t0 = sim.time();
    const double dt_guess = plan.dt > 0 ? plan.dt : std::min(sim.solver().options().dt_max, sim.solver().stable_dt());
    const double steps_left_est = plan.steps_per_cycle > 0 ? double(total_steps - start_step) : (t_end - t0) / dt_guess;
    const std::size_t ib_bytes = res.bytes - solver_bytes;
    *log << fmt::format("flapstab cfd: {} ({}), Re = {:.4g} (U_ref = 2 Phi f R = {:.4g} m/s, L_ref = mean chord = "
                        "{:.4g} m, nu = {:.4g} m^2/s)\n",
                        c.insect.name, c.path, plan.reynolds, plan.u_ref, plan.l_ref, plan.nu);
    *log << fmt::format("  grid {} x {} x {} = {} cells, fine spacing {:.4g} m ({:.1f} cells per mean chord), domain "
                        "[{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] m\n",
                        grid.axis[0].n, grid.axis[1].n, grid.axis[2].n, res.cells, plan.h_actual, plan.chord_cells,
                        plan.domain_lo.x(), plan.domain_hi.x(), plan.domain_lo.y(), plan.domain_hi.y(),
                        plan.domain_lo.z(), plan.domain_hi.z());
    *log << fmt::format("  memory {:.1f} MiB ({:.0f} bytes per cell: solver {:.1f} MiB, immersed boundary {:.1f} MiB)\n",
                        res.bytes / 1048576.0, double(res.bytes) / res.cells, solver_bytes / 1048576.0,
                        ib_bytes / 1048576.0);
    *log << fmt::format("  {} cycles of {:.4g} s, {}{} steps{}\n", plan.cycles, plan.period,
                        plan.steps_per_cycle > 0 ? "" : "about ", long(std::ceil(steps_left_est)),
                        plan.steps_per_cycle > 0 ? fmt::format(" (dt = T/{} = {:.4g} s)", plan.steps_per_cycle, plan.dt)
                                                 : fmt::format(" (adaptive dt, CFL {})", s.cfl));
    if (D.distributed())
      *log << fmt::format("  over {} MPI ranks: z slabs of {} planes; {:.1f} MiB on the largest rank; rank 0 writes "
                          "the files\n",
                          D.size(), slab_planes_text(sim.solver()), largest_rank_bytes / 1048576.0);
    if (plan.sponge_width > 0)
      *log << fmt::format("  sponge layer {:.4g} m deep along every face, relaxing towards the far field at up to "
                          "{:.4g} /s ({:g} per wingbeat)\n",
                          plan.sponge_width, plan.sponge_rate, plan.sponge_rate * plan.period);
    if (ck) *log << "  restarting from " << res.restarted_from << fmt::format(" (step {}, t = {:.6g} s)\n", start_step, t0);
    for (const auto& w : plan.warnings) *log << "  warning: " << w << "\n";
  }

  // Observers (files created lazily: bad input and dry runs write nothing). One run per directory at a time.
  std::optional<ExclusiveRun> exclusive;
  if (write)
    on_root(D, [&] {
      exclusive.emplace(o.directory, "-o");  // first: a run still writing there is named as such
      // A run from rest into the directory of another run would overwrite that run's forces.csv at its first
      // checkpoint (the earlier checkpoints could then no longer continue), and the other run's later-numbered
      // checkpoints would outlive this run's own (the newest two by step are kept) and be what --restart picked up.
      if (ck) return;
      const auto earlier = checkpoints_in(ckdir);
      if (!earlier.empty())
        throw InputError(ckdir, "--restart",
                         fmt::format("holds {} checkpoint{} of an earlier run (the newest at step {}), and this run "
                                     "starts from rest: it would overwrite that run's forces.csv",
                                     earlier.size(), earlier.size() == 1 ? "" : "s", earlier.back().first),
                         "--restart to continue that run, or another output directory (or the old one removed) to "
                         "start again");
    });
  ForcesCsv csv(write ? o.directory + "/forces.csv" : std::string(), sim.part_count());
  if (D.distributed()) csv.set_decomposition(dec);
  if (write && ck) csv.keep_earlier(o.directory + "/forces.csv", start_step);  // InputError when rows are missing
  Checkpointer checkpoints(ckdir, s.checkpoints_per_cycle,
                           {{"reynolds", plan.reynolds}, {"nu", plan.nu}, {"density", plan.rho}, {"period", plan.period}},
                           {{"case_hash", hash}, {"case", c.path}, {"grid", grid_text}}, &csv);
  if (ck) checkpoints.set_last(res.restarted_from, start_step);
  const double weight = c.insect.weight();
  FieldOutput fields(o.directory + "/fields", s.fields_per_cycle,
                     s.field_precision == "float32" ? FieldPrecision::float32 : FieldPrecision::float64,
                     s.field_files == "per-rank");
  SurfaceOutput surfaces(o.directory + "/surfaces", s.surfaces_per_cycle);
  ProgressLog progress(log, o.progress_seconds, total_steps, t_end);
  std::vector<StepObserver*> observers = {&csv, &progress};
  if (write) observers.insert(observers.end(), {&fields, &surfaces, &checkpoints});
  // Force partitioning: before the checkpoints in the list, so a checkpoint's flush holds this step's sample.
  std::optional<fpm::FpmObserver> partition;
  if (s.fpm.enabled && o.bodies) {
    partition.emplace(sim, s.fpm, write ? o.directory : std::string());
    if (write && ck) partition->keep_earlier(o.directory + "/fpm.csv", start_step);
    observers.insert(observers.begin() + 1, &*partition);
    checkpoints.also_flush([&] { partition->flush(); });
  }

  auto diverged = [&](const StepFailure& e) -> SolveError {
    try {
      csv.flush();
    } catch (...) {
    }
    return SolveError(fmt::format(
        "the CFD run diverged at step {} (t = {:.6g} s, t/T = {:.4f}): {}; {}", e.step(), e.time(), e.time() / plan.period,
        e.why(),
        checkpoints.last().empty() ? std::string("no checkpoint was written")
                                   : fmt::format("the last checkpoint, {} (step {}), is kept; lower the time step "
                                                 "(aero.cfd.steps_per_cycle or aero.cfd.cfl) and restart",
                                                 checkpoints.last(), checkpoints.last_step())));
  };

  if (write && !ck) {  // the initial state: fields, surfaces, and a checkpoint to fall back on
    if (s.fields_per_cycle > 0) fields.write(sim);
    if (s.surfaces_per_cycle > 0) surfaces.write(sim);
    if (s.checkpoints_per_cycle > 0) checkpoints.write(sim);
  }

  for (auto* ob : observers) ob->on_start(sim);
  auto finish = [&] {
    res.steps = sim.step();
    res.wall_seconds = std::chrono::duration<double>(clock::now() - t_start).count();
    res.seconds_per_step_estimate = progress.seconds_per_step_estimate();
    res.seconds_per_step = progress.seconds_per_step();
    res.rows = csv.rows();
    if (partition) {
      res.fpm_rows = partition->rows();
      res.fpm_regions = partition->region_names();
      res.fpm_seconds = partition->seconds();
    }
  };
  std::optional<InterruptGuard> signals;
  if (o.handle_signals && !o.dry_run) signals.emplace();
  const long stop_at = o.steps > 0 ? start_step + o.steps : 0;
  while (in_run(sim.step(), sim.time())) {
    StepReport r;
    try {
      r = sim.advance();
    } catch (const StepFailure& e) {
      throw diverged(e);
    }
    for (auto* ob : observers) ob->on_step(sim, r);
    if (o.dry_run && progress.estimated()) break;
    if (o.stop_after_steps > 0 && sim.step() >= o.stop_after_steps && in_run(sim.step(), sim.time())) {
      finish();
      csv.flush();
      if (partition) partition->flush();
      return res;
    }
    // over ranks a signal stops them all at the same step (it may reach them at different times)
    if (const int sig = D.distributed() ? int(D.max(interrupt_requested())) : interrupt_requested();
        sig != 0 && in_run(sim.step(), sim.time())) {
      // Stop at the end of the step: the rows and a checkpoint of this step, then say how to continue.
      finish();
      std::string saved = "nothing was saved (no output directory)";
      if (write) {
        if (checkpoints.last_step() != sim.step()) checkpoints.write(sim);  // flushes forces.csv first
        saved = fmt::format("forces.csv and {} are written; continue with --restart", checkpoints.last());
      }
      clear_interrupt();
      throw Interrupted(sig, fmt::format("the CFD run stopped on {} at step {} (t = {:.6g} s, t/T = {:.4f}): {}",
                                         signal_name(sig), sim.step(), sim.time(), sim.time() / plan.period, saved));
    }
    if (stop_at > 0 && sim.step() >= stop_at && in_run(sim.step(), sim.time())) {
      res.status = "stopped";
      break;
    }
  }
  finish();
  if (o.dry_run) {
    if (partition && log) {  // the cost of one partition against the steps between two
      const auto t0 = clock::now();
      partition->sample(sim);
      const double sample_s = std::chrono::duration<double>(clock::now() - t0).count();
      const double steps_per_sample =
          (plan.steps_per_cycle > 0 ? plan.steps_per_cycle : plan.period / std::max(sim.last_dt(), 1e-300)) /
          s.fpm.samples_per_cycle;
      const double step_s = progress.seconds_per_step_estimate();
      *log << fmt::format("  force partitioning: {:.3g} s per sample ({} potentials, {:.0f} iterations each on "
                          "average, from rest), {} samples per wingbeat: about {:.2f} x the cost of the run without "
                          "(usually high: this sample starts from zero potentials, a run's from the last ones')\n",
                          sample_s, partition->components().size() * s.fpm.parts.size(),
                          partition->mean_potential_iterations(), s.fpm.samples_per_cycle,
                          step_s > 0 ? 1 + sample_s / (steps_per_sample * step_s) : 0.0);
    }
    return res;
  }
  if (res.status.empty()) res.status = "complete";

  // Rows of the last wingbeat, with the one at its start when the run has it (the previous wingbeat's last step).
  res.last_cycle = csv.since((plan.cycles - 1) * plan.period, plan.period);
  std::vector<CfdLoadRow> all = csv.earlier();
  all.insert(all.end(), csv.rows().begin(), csv.rows().end());
  res.result = cfd_run_result(all, plan, weight);
  if (partition) {
    if (res.result.available) {
      res.fpm_means_json = partition->means(res.result.from_s, res.result.to_s, plan.period, weight).dump();
      res.fpm_summary = partition->summary(res.result.from_s, res.result.to_s, plan.period);
    }
  }
  if (write) {
    for (auto* ob : observers) ob->on_end(sim);
    on_root(D, [&] {
      write_run_json(o.directory + "/run.json", c, hash, sim, res);
      for (const std::string& d : {o.directory, ckdir, o.directory + "/fields", o.directory + "/surfaces"})
        remove_stale_temporaries(d);  // left by killed runs
    });
  }
  if (log && !res.fpm_summary.empty()) *log << res.fpm_summary;
  if (log && partition)
    *log << fmt::format("  force partitioning: {} samples in {} ({:.0f} potential iterations per solve on average)\n",
                        partition->samples(), fmt_seconds(res.fpm_seconds), partition->mean_potential_iterations());
  if (log)
    *log << fmt::format("  done: {} steps in {}, {:.3g} s per step ({:.0f} ns per cell per step)\n",
                        res.steps - res.start_step, fmt_seconds(res.wall_seconds), res.seconds_per_step,
                        1e9 * res.seconds_per_step / res.cells);
  return res;
}

CfdRunResult cfd_run_result(const std::vector<CfdLoadRow>& rows, const CfdPlan& plan, double weight) {
  CfdRunResult r;
  r.weight = weight;
  if (rows.empty()) return r;
  const double T = plan.period, eps = 1e-9;
  const double t_last = rows.back().time;
  const int full = int(std::floor(t_last / T + eps));  // complete wingbeats
  if (full >= 2) {
    r.wingbeat = full;
    r.complete = true;
    r.note = fmt::format("wingbeat {} of the run (the last complete one); wingbeat 1, the start-up from rest, "
                         "excluded", full);
  } else if (full == 1) {
    r.wingbeat = 1;
    r.complete = true;
    r.includes_startup = true;
    r.note = "wingbeat 1, the start-up from rest: the only complete wingbeat, not a hover result (run 2 or more "
             "wingbeats: --cycles)";
  } else {
    r.wingbeat = 1;
    r.includes_startup = true;
    r.note = fmt::format("less than a wingbeat (t/T = {:.3f}) from rest: a smoke run, not a hover result", t_last / T);
  }
  r.from_s = r.complete ? (r.wingbeat - 1) * T : 0.0;
  r.to_s = r.complete ? r.wingbeat * T : t_last;
  std::vector<const CfdLoadRow*> w;
  for (const auto& row : rows)
    if (row.time > r.from_s - eps * T && row.time < r.to_s + eps * T) w.push_back(&row);
  if (w.empty()) return r;
  r.available = true;
  // Time-weighted (trapezoid rule over the rows; one row: its value).
  const double span = w.back()->time - w.front()->time;
  auto avg = [&](auto get) {
    if (w.size() < 2 || span <= 0) return get(*w.back());
    decltype(get(*w.back())) a = get(*w.back()) * 0.0;
    for (std::size_t k = 1; k < w.size(); ++k) a += 0.5 * (get(*w[k]) + get(*w[k - 1])) * (w[k]->time - w[k - 1]->time);
    return decltype(a)(a / span);
  };
  r.mean.force = avg([](const CfdLoadRow& x) -> Vec3 { return x.total().force; });
  r.mean.moment = avg([](const CfdLoadRow& x) -> Vec3 { return x.total().moment; });
  r.parts = w.back()->parts;
  for (int i = 0; i < r.parts; ++i) {
    r.part_mean[i].force = avg([i](const CfdLoadRow& x) -> Vec3 { return x.part[i].wrench().force; });
    r.part_mean[i].moment = avg([i](const CfdLoadRow& x) -> Vec3 { return x.part[i].wrench().moment; });
  }
  r.wing_power = avg([](const CfdLoadRow& x) { return x.wing_power; });
  r.lift_over_weight = weight > 0 ? -r.mean.force.z() / weight : 0.0;
  return r;
}

std::string cfd_run_result_text(const CfdRunResult& r) {
  if (!r.available) return "  result: no rows\n";
  const Vec3 F = 1e3 * r.mean.force, M = 1e3 * r.mean.moment;
  return fmt::format(
      "  result over {} (t = {:.6g} to {:.6g} s):\n"
      "    mean force  ({:+.4g}, {:+.4g}, {:+.4g}) mN   lift / weight = {:.3f} (weight {:.4g} mN; lift = -F_z, z down)\n"
      "    mean moment ({:+.4g}, {:+.4g}, {:+.4g}) mN m about O   wing power {:.4g} mW\n",
      r.note, r.from_s, r.to_s, F.x(), F.y(), F.z(), r.lift_over_weight, 1e3 * r.weight, M.x(), M.y(), M.z(),
      1e3 * r.wing_power);
}

}  // namespace flapstab::ns
