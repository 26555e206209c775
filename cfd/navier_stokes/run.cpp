// The CFD run driver (run.hpp): restart bookkeeping, the estimate, the loop over the Simulation and its observers,
// run.json.
#include "cfd/navier_stokes/run.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <ostream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <omp.h>

#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "core/hash.hpp"

namespace flapstab::ns {

namespace fs = std::filesystem;

std::string case_hash(const std::string& path) { return fnv1a64_file(path); }

namespace {

void write_run_json(const std::string& path, const Case& c, const std::string& hash, const Simulation& sim,
                    const CfdResult& res) {
  const CfdPlan& plan = res.plan;
  const CfdSettings& s = c.aero.cfd;
  const BodyMotion& motion = sim.motion();
  const Grid& grid = sim.grid();
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
                  {"threads", omp_get_max_threads()}};
  // Mean loads over the last wingbeat (time-weighted, trapezoid rule over the rows).
  nlohmann::json mean;
  if (res.last_cycle.size() >= 2) {
    const double span = res.last_cycle.back().time - res.last_cycle.front().time;
    auto avg = [&](auto get) {
      double a = 0;
      for (std::size_t k = 1; k < res.last_cycle.size(); ++k)
        a += 0.5 * (get(res.last_cycle[k]) + get(res.last_cycle[k - 1])) *
             (res.last_cycle[k].time - res.last_cycle[k - 1].time);
      return span > 0 ? a / span : get(res.last_cycle.back());
    };
    for (int i = 0; i < 4; ++i) {
      nlohmann::json m;
      auto wr = [i](const CfdLoadRow& r) {
        if (i == 3) return r.total();
        const auto& q = r.part[i];
        return Wrench{q.pressure_force + q.viscous_force, q.pressure_moment + q.viscous_moment};
      };
      for (int a = 0; a < 3; ++a) {
        m["force_N"].push_back(avg([&](const CfdLoadRow& r) { return wr(r).force[a]; }));
        m["moment_N_m"].push_back(avg([&](const CfdLoadRow& r) { return wr(r).moment[a]; }));
      }
      mean[i == 3 ? "total" : part_names[i]] = m;
    }
    mean["wing_power_W"] = avg([](const CfdLoadRow& r) { return r.wing_power; });
    mean["from_s"] = res.last_cycle.front().time;
    mean["to_s"] = res.last_cycle.back().time;
  }
  j["mean_loads_last_cycle"] = mean;
  write_file_atomic(path, j.dump(2) + "\n");
}

}  // namespace

CfdResult run_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, const CfdRunOptions& o) {
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  const CfdSettings& s = c.aero.cfd;
  std::ostream* log = o.log;
  CfdResult res;
  res.plan = plan_cfd(c, kin, motion, o.cycles);
  const CfdPlan& plan = res.plan;
  const bool write = !o.directory.empty() && !o.dry_run;
  if (o.restart && o.directory.empty()) throw InputError("", "--restart", "needs an output directory", "-o DIR");

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
  }

  SimulationOptions so;
  so.bodies = o.bodies;
  so.initial_velocity = o.initial_velocity;
  Simulation sim(c, kin, motion, plan, so);
  if (ck) {
    sim.restore(read_state(*ck, sim.grid().shape()));
    res.start_step = sim.step();
  }
  const long start_step = sim.step();
  const Grid& grid = sim.grid();
  res.cells = sim.cells();
  res.bytes = sim.bytes();
  const double t_end = plan.cycles * plan.period;
  const long total_steps = plan.steps_per_cycle > 0 ? long(plan.cycles) * plan.steps_per_cycle : 0;
  const auto in_run = [&](long k, double t) {
    return plan.steps_per_cycle > 0 ? k < total_steps : t < t_end * (1 - 1e-12);
  };
  if (log) {
    const double t0 = sim.time();
    const double dt_guess = plan.dt > 0 ? plan.dt : std::min(sim.solver().options().dt_max, sim.solver().stable_dt());
    const double steps_left_est = plan.steps_per_cycle > 0 ? double(total_steps - start_step) : (t_end - t0) / dt_guess;
    const std::size_t ib_bytes = res.bytes - sim.solver().bytes();
    *log << fmt::format("flapstab cfd: {} ({}), Re = {:.4g} (U_ref = 2 Phi f R = {:.4g} m/s, L_ref = mean chord = "
                        "{:.4g} m, nu = {:.4g} m^2/s)\n",
                        c.insect.name, c.path, plan.reynolds, plan.u_ref, plan.l_ref, plan.nu);
    *log << fmt::format("  grid {} x {} x {} = {} cells, fine spacing {:.4g} m ({:.1f} cells per mean chord), domain "
                        "[{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] m\n",
                        grid.axis[0].n, grid.axis[1].n, grid.axis[2].n, res.cells, plan.h_actual, plan.chord_cells,
                        plan.domain_lo.x(), plan.domain_hi.x(), plan.domain_lo.y(), plan.domain_hi.y(),
                        plan.domain_lo.z(), plan.domain_hi.z());
    *log << fmt::format("  memory {:.1f} MiB ({:.0f} bytes per cell: solver {:.1f} MiB, immersed boundary {:.1f} MiB)\n",
                        res.bytes / 1048576.0, double(res.bytes) / res.cells, sim.solver().bytes() / 1048576.0,
                        ib_bytes / 1048576.0);
    *log << fmt::format("  {} cycles of {:.4g} s, {}{} steps{}\n", plan.cycles, plan.period,
                        plan.steps_per_cycle > 0 ? "" : "about ", long(std::ceil(steps_left_est)),
                        plan.steps_per_cycle > 0 ? fmt::format(" (dt = T/{} = {:.4g} s)", plan.steps_per_cycle, plan.dt)
                                                 : fmt::format(" (adaptive dt, CFL {})", s.cfl));
    if (ck) *log << "  restarting from " << res.restarted_from << fmt::format(" (step {}, t = {:.6g} s)\n", start_step, t0);
    for (const auto& w : plan.warnings) *log << "  warning: " << w << "\n";
  }

  // Observers (files created lazily: bad input and dry runs write nothing).
  if (write) fs::create_directories(o.directory);
  ForcesCsv csv(write ? o.directory + "/forces.csv" : std::string());
  if (write && ck) csv.keep_earlier(o.directory + "/forces.csv", start_step);
  Checkpointer checkpoints(ckdir, s.checkpoints_per_cycle,
                           {{"reynolds", plan.reynolds}, {"nu", plan.nu}, {"density", plan.rho}, {"period", plan.period}},
                           {{"case_hash", hash}, {"case", c.path}, {"grid", grid_text}}, &csv);
  if (ck) checkpoints.set_last(res.restarted_from, start_step);
  FieldOutput fields(o.directory + "/fields", s.fields_per_cycle,
                     s.field_precision == "float32" ? FieldPrecision::float32 : FieldPrecision::float64);
  SurfaceOutput surfaces(o.directory + "/surfaces", s.surfaces_per_cycle);
  ProgressLog progress(log, o.progress_seconds, total_steps, t_end);
  std::vector<StepObserver*> observers = {&csv, &progress};
  if (write) observers.insert(observers.end(), {&fields, &surfaces, &checkpoints});

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
  };
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
      return res;
    }
  }
  finish();
  if (o.dry_run) return res;

  // Rows of the last wingbeat, with the one at its start when the run has it (the previous wingbeat's last step).
  res.last_cycle = csv.since((plan.cycles - 1) * plan.period, plan.period);
  if (write) {
    for (auto* ob : observers) ob->on_end(sim);
    write_run_json(o.directory + "/run.json", c, hash, sim, res);
  }
  if (log)
    *log << fmt::format("  done: {} steps in {}, {:.3g} s per step ({:.0f} ns per cell per step)\n",
                        res.steps - res.start_step, fmt_seconds(res.wall_seconds), res.seconds_per_step,
                        1e9 * res.seconds_per_step / res.cells);
  return res;
}

}  // namespace flapstab::ns
