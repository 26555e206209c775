// flapstab fly with [aero] model = "cfd": free flight coupled to the Navier-Stokes solver (flight/cfd_flight.hpp).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <complex>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "apps/flight_command.hpp"
#include "apps/plots.hpp"
#include "apps/results_json.hpp"
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "trim/parameters.hpp"
#include "trim/refine.hpp"
#include "cfd/navier_stokes/cfd_model.hpp"
#include "cfd/navier_stokes/decomposition.hpp"
#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/observers.hpp"
#include "cfd/navier_stokes/plan.hpp"
#include "cfd/navier_stokes/run.hpp"
#include "cfd/navier_stokes/solver_io.hpp"
#include "core/atomic_write.hpp"
#include "core/body_state.hpp"
#include "core/errors.hpp"
#include "core/hash.hpp"
#include "core/interrupt.hpp"
#include "flight/cfd_flight.hpp"
#include "flight/controller.hpp"
#include "flight/hover_model.hpp"

namespace flapstab {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

std::string state_column(int i) {
  std::string u = body_state_units()[std::size_t(i)];
  std::replace(u.begin(), u.end(), '/', '_');
  return fmt::format("{}_{}", body_state_names()[std::size_t(i)], u);
}

std::string steps_header(const std::vector<TrimParameterSpec>& actuators) {
  std::string h = "t_s,step,wingbeat,cfl";
  for (int i = 0; i < 12; ++i) h += fmt::format(",{}", state_column(i));
  h += ",X_N,Y_N,Z_N,L_N_m,M_N_m,N_N_m,buoyancy_X_N,buoyancy_Y_N,buoyancy_Z_N,buoyancy_L_N_m,buoyancy_M_N_m,"
       "buoyancy_N_N_m,power_W";
  for (const auto& a : actuators) h += fmt::format(",command_{}", a.label());
  return h + "\n";
}

std::string steps_row(const CfdFlightStep& s, double T) {
  std::vector<double> row{s.time, double(s.step), s.time / T, s.cfl};
  for (int i = 0; i < 12; ++i) row.push_back(s.x(i));
  for (const Wrench* w : {&s.aero, &s.buoyancy}) {
    for (int i = 0; i < 3; ++i) row.push_back(w->force(i));
    for (int i = 0; i < 3; ++i) row.push_back(w->moment(i));
  }
  row.push_back(s.power);
  for (double u : s.command) row.push_back(u);
  return fmt::format("{:.17g}\n", fmt::join(row, ","));
}

// A row of steps.csv. file_commands: the command columns the file's header names (command_<actuator>); the step's
// command is laid out for `actuators`, an actuator the file lacks at zero (a reference flight written under another
// controller, or before the command columns existed, flew open loop: its commands are zero).
CfdFlightStep parse_steps_row(const std::string& line, const std::vector<std::string>& file_commands,
                              const std::vector<TrimParameterSpec>& actuators) {
  std::vector<double> v;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) v.push_back(std::stod(cell));
  if (v.size() != 4 + 12 + 12 + 1 + file_commands.size()) throw std::invalid_argument("row length");
  CfdFlightStep s;
  s.time = v[0];
  s.step = long(v[1]);
  s.cfl = v[3];
  for (int i = 0; i < 12; ++i) s.x(i) = v[std::size_t(4 + i)];
  std::size_t k = 16;
  for (Wrench* w : {&s.aero, &s.buoyancy}) {
    for (int i = 0; i < 3; ++i) w->force(i) = v[k++];
    for (int i = 0; i < 3; ++i) w->moment(i) = v[k++];
  }
  s.power = v[k++];
  s.command.assign(actuators.size(), 0.0);
  for (std::size_t a = 0; a < actuators.size(); ++a)
    for (std::size_t f = 0; f < file_commands.size(); ++f)
      if (file_commands[f] == fmt::format("command_{}", actuators[a].label())) s.command[a] = v[k + f];
  return s;
}

// The command columns a steps.csv header names.
std::vector<std::string> command_columns(const std::string& header) {
  std::vector<std::string> out;
  std::stringstream ss(header);
  std::string cell;
  while (std::getline(ss, cell, ','))
    if (cell.rfind("command_", 0) == 0) out.push_back(cell);
  return out;
}

// A controller's settings as text for the flight checkpoint's key: a changed gain, latency, limit or update rule
// does not continue another controller's flight.
std::string controller_key(const ControllerSpec& c) {
  if (c.empty()) return "";  // open loop: the key as before closed loops existed
  std::string k = c.update == ControlUpdate::wingbeat ? "wingbeat" : "continuous";
  for (const auto& a : c.actuators) k += fmt::format(";{}[{:.17g},{:.17g}]", a.label(), a.lower, a.upper);
  for (const auto& t : c.terms)
    k += fmt::format(";{}>{}:{:.17g},{:.17g},{:.17g}", t.state, t.actuator, t.gain, t.latency_s, t.filter_time_s);
  return k;
}

}  // namespace

int run_fly_cfd(const FlightCommandOptions& o, const Case& c, const std::string& dir, DofSet dofs, double wingbeats,
                const std::vector<int>& moving, std::shared_ptr<const ns::Decomposition> ranks) {
  const auto t0 = std::chrono::steady_clock::now();
  // Over MPI ranks every flow runs over all of them; rank 0 prints, and writes the files for all (from_root: its
  // failure is every rank's).
  if (ranks && !ranks->distributed()) ranks.reset();
  const ns::Decomposition one;
  const ns::Decomposition& D = ranks ? *ranks : one;
  const bool talk = !o.quiet && D.rank() == 0;
  // The kinematics: the quasi-steady trim refined on the CFD cycle means ([aero.cfd] trim_iterations), as the CFD
  // stability chain takes them (flapstab trim-hover / analyze with model = "cfd"), on the same grid.
  Case qc = c;
  qc.aero.model = "quasi-steady";
  const auto qs = make_aero_model(qc);
  const TrimResult start = trim_hover(qc, *qs);
  if (!start.converged)
    throw SolveError(fmt::format("{}: the quasi-steady trim that starts the CFD trim did not converge ({})", c.path,
                                 start.message));
  // The controller at the quasi-steady trim (its actuators' limits widen the fine box below).
  const ControllerSpec planned = controller_from_case(c, start.kinematics);
  std::ostream* log = talk ? &std::cout : nullptr;
  auto model = std::make_unique<ns::CfdModel>(c, log, dir + "/cfd_cache");
  if (ranks) model->run_over(ranks);
  std::vector<Kinematics> extremes = trim_extreme_kinematics(c, start);
  // The controller may drive each actuator to its limits: the fine box holds the wings there too (each actuator at
  // each limit, the others at the quasi-steady trim; a refined trim that moves an actuated parameter, or several
  // actuators at their limits at once, can still take a wing out, which stops the run with BodyLeftGrid). A case with
  // a controller therefore runs on a larger grid than the same case without one.
  if (!planned.empty()) {
    const TrimParameterization par(start.kinematics, planned.actuators, c.path);
    for (std::size_t j = 0; j < planned.actuators.size(); ++j)
      for (const double limit : {planned.actuators[j].lower, planned.actuators[j].upper}) {
        std::vector<double> v = par.initial();
        v[j] = limit;
        extremes.push_back(par.apply(v));
      }
  }
  model->plan_for(extremes);
  const TrimResult trim = refine_trim(c, *model, *qs, start,
                                      RefineSettings{c.aero.cfd.trim_tolerance, c.aero.cfd.trim_iterations}, log);
  const Kinematics& kin = trim.kinematics;
  if (trim.model_runs > 1) {  // the kept hover is of the start's kinematics: the trimmed one's own, same grid
    model = std::make_unique<ns::CfdModel>(c, log, dir + "/cfd_cache_trimmed");
    if (ranks) model->run_over(ranks);
    model->plan_for(extremes);
  }
  const double T = kin.period();
  BodyStateVector x0 = BodyStateVector::Zero();
  for (const auto& [name, value] : c.flight.perturbation) x0(*body_state_index(name)) += value;
  // A Floquet-mode perturbation is the quasi-steady model's mode (its periodic orbit at phase 0, where the kept
  // hover state starts too): the CFD model's own Floquet analysis needs its derivative table (flapstab floquet).
  std::complex<double> mode_multiplier = 0;
  if (!c.flight.mode.empty()) {
    const HoverModel h = hover_model(qc, *qs, {});
    x0 += floquet_mode_perturbation(h, c.flight.mode, c.flight.mode_amplitude, &mode_multiplier);
  }
  const bool from_hover = c.flight.start == "periodic-orbit";

  // The flow to start from: the kept periodic hover (tethered, reused from DIR/cfd_cache when it was computed
  // before), or rest.
  model->run(c.insect, kin, BodyMotion{}, AeroRunOptions{});  // the hover (reused when computed before)
  const ns::SimulationState* hover = from_hover ? model->hover_state() : nullptr;
  const ns::CfdPlan plan = *model->plan();
  const ControllerSpec controller = controller_from_case(c, kin);
  const FlightDynamics dyn(*model, c.insect, kin,
                           controller.actuators.empty() ? controller_actuators(c) : controller.actuators, dofs,
                           std::nullopt, false, c.path);
  const std::vector<TrimParameterSpec>& actuators = dyn.actuators();
  const int spc = plan.steps_per_cycle;
  const long total = std::lround(wingbeats * spc);
  const int spw = std::max(1, std::min(c.flight.samples_per_wingbeat, spc));
  const int stride = std::max(1, spc / spw);
  // With a perturbation from the hover, the reference is the unperturbed coupled flight from the same state (the
  // CFD analogue of the periodic orbit): flown first, then the perturbed flight; the deviation is their difference.
  const bool with_reference = from_hover && x0 != BodyStateVector::Zero();
  // [flight] cfd_reference = "closed-loop": the reference flies under the controller too, and both flights' sensors
  // see the deviation from the tethered hover (the body at rest at O), as the quasi-steady free flight's see the
  // deviation from its periodic orbit; the deviation reported stays the perturbed flight minus the reference.
  const bool closed_reference = with_reference && !controller.empty() && c.flight.cfd_reference == "closed-loop";

  // The tethered hover's cycle-mean residual: its last wingbeat's mean wrench with the weight (body at rest at O, so
  // body axes = grid axes; the wings' mean inertial loads vanish over a wingbeat and O is the mean centre of mass).
  Wrench residual;
  const double weight = c.insect.total_mass() * c.insect.gravity;
  const double mc = weight * c.insect.wing.mean_chord;

  std::string pert = c.flight.cfd_residual + ";";
  for (const auto& [name, value] : c.flight.perturbation) pert += fmt::format("{}={:.17g};", name, value);
  if (!c.flight.mode.empty()) pert += fmt::format("mode={}:{:.17g};", c.flight.mode, c.flight.mode_amplitude);
  const std::string case_key = ns::case_hash(c.path);

  struct Flown {
    std::vector<CfdFlightStep> steps;
    std::string stop, checkpoint;
    bool resumed = false;
    double wall_s = 0;
    json replans = json::array();  // the fine box's re-plans (with those before a resume)
  };
  std::optional<Flown> ref_flight;
  // What the sensors compare with at flight time s: the unperturbed flight's state (linear between its steps), or
  // the tethered hover (the body at rest at O).
  auto reference_state = [&](double s) -> BodyStateVector {
    if (!ref_flight) return BodyStateVector::Zero();
    const auto& st = ref_flight->steps;
    const double s0 = st.front().time;
    const auto it = std::upper_bound(st.begin(), st.end(), s, [&](double v, const CfdFlightStep& q) {
      return v < q.time - s0;
    });
    if (it == st.begin()) return st.front().x;
    if (it == st.end()) return st.back().x;
    const CfdFlightStep& a = *(it - 1);
    const CfdFlightStep& b = *it;
    const double w = (s - (a.time - s0)) / (b.time - a.time);
    return (1 - w) * a.x + w * b.x;
  };
  const double max_angle = FlightOptions{}.max_pitch_deg * M_PI / 180;
  const InterruptGuard guard;
  bool printed = false;
  // One coupled flight from x_init, resumable from its own checkpoint (name: "flight" or "reference").
  auto fly = [&](const BodyStateVector& x_init, const std::string& name, long limit) {
    Flown f;
    CfdFlight fl(c, dyn, plan, ranks);
    fl.set_replanning(c.flight.cfd_replan);
    if (closed_reference)
      fl.set_controller(controller, [](double) { return BodyStateVector::Zero().eval(); });
    else if (name == "flight" && !controller.empty())
      fl.set_controller(controller, reference_state);
    if (const auto* h = model->hover_record(); h && !h->cycles.empty()) {
      residual = h->cycles.back().mean;
      Vec3 centroid;
      const double V = fl.simulation().part_volume(0, &centroid);
      residual.force += Vec3(0, 0, weight - plan.rho * V * c.insect.gravity);
      residual.moment += centroid.cross(Vec3(0, 0, -plan.rho * V * c.insect.gravity));
    }
    if (c.flight.cfd_residual == "cancel") fl.set_offset(Wrench{-residual.force, -residual.moment});
    if (talk && !printed) {
      printed = true;
      fmt::print("{}: free flight of '{}' coupled to the Navier-Stokes solver, {} degrees of freedom, {} wingbeats "
                 "from the {}{}\n",
                 c.path, c.insect.name, dof_set_name(dofs), wingbeats,
                 from_hover ? "kept periodic hover (tethered)" : "flow at rest",
                 with_reference ? "; the unperturbed flight first (the reference), then the perturbed one" : "");
      if (!c.flight.mode.empty())
        fmt::print("  perturbation along the quasi-steady model's {} Floquet mode (|mu| = {:.4f} per wingbeat), "
                   "amplitude {}\n",
                   c.flight.mode, std::abs(mode_multiplier), c.flight.mode_amplitude);
      if (closed_reference)
        fmt::print("  controller: {}; both flights fly under it, and it senses the deviation from the tethered hover "
                   "(body at rest at O) ([flight] cfd_reference = \"closed-loop\")\n",
                   controller.description);
      else if (!controller.empty())
        fmt::print("  controller: {}; it senses the deviation from the {} (the reference flight flies open loop)\n",
                   controller.description, with_reference ? "unperturbed flight" : "tethered hover (body at rest at O)");
      if (c.flight.cfd_reference == "closed-loop" && !closed_reference)
        fmt::print("  note: [flight] cfd_reference = \"closed-loop\" has no effect here (it needs a [control] table "
                   "and a perturbation, i.e. a reference flight)\n");
      fmt::print("  the tethered hover's residual (last wingbeat's mean wrench with the weight): X {:+.3f} W, Z "
                 "{:+.3f} W, M {:+.4f} W c; {}\n",
                 residual.force.x() / weight, residual.force.z() / weight, residual.moment.y() / mc,
                 c.flight.cfd_residual == "cancel" ? "cancelled by a constant wrench ([flight] cfd_residual = \"cancel\")"
                                                   : "kept: the insect flies with it ([flight] cfd_residual = \"keep\")");
      const double ratio = fl.forced_fluid_mass() / fl.body_mass();
      fmt::print("  explicit coupling: the fluid the forcing holds solid weighs {:.3g} of the insect{}\n", ratio,
                 ratio > 0.1 ? " -- WARNING: above 0.1 the lagged loads may feed back more than the body's mass and "
                               "the coupling can diverge (docs/theory/fluid-body-coupling.md)"
                             : " (the lagged loads' feedback is small)");
      fmt::print("  grid {} cells ({:.1f} per mean chord), {} steps per wingbeat; fine box [{:.4g}, {:.4g}] x "
                 "[{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] m, {:.3g} mm of room around the swept volume: {}\n",
                 ns::plan_grid(plan).cells(), plan.chord_cells, spc, plan.fine_lo.x(), plan.fine_hi.x(),
                 plan.fine_lo.y(), plan.fine_hi.y(), plan.fine_lo.z(), plan.fine_hi.z(), fl.room() * 1e3,
                 c.flight.cfd_replan ? "re-planned around the body when a part has used half of it"
                                     : "the body must stay in it ([flight] cfd_replan = false)");
      if (ranks)
        fmt::print("  every flow over {} MPI ranks: z slabs of {} planes; rank 0 writes the files\n", D.size(),
                   ns::slab_planes_text(fl.simulation().solver()));
      std::fflush(stdout);
    }
    // The key names the start too: the hover's last-wingbeat mean wrench (17 digits) stands for the hover state and
    // the kinematics it was run with, so a flight is not continued from a checkpoint of another trim or hover.
    std::string hover_id;
    if (const auto* h = model->hover_record(); h && !h->cycles.empty()) {
      const Wrench& m = h->cycles.back().mean;
      hover_id = fmt::format("{:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}", m.force.x(), m.force.y(), m.force.z(),
                             m.moment.x(), m.moment.y(), m.moment.z());
    }
    const std::string key = fnv1a64_hex(fmt::format("{}|{}|{}|{}|{}|{}", case_key, c.flight.start, dof_set_name(dofs),
                                                    name == "reference"
                                                        ? std::string("reference") +
                                                              (closed_reference ? controller_key(controller) : "")
                                                        : pert + controller_key(controller) +
                                                              (closed_reference ? ";senses the hover" : ""),
                                                    name, hover_id));
    const std::string ck_path = dir + "/" + name + "_checkpoint.h5", ck_rows = dir + "/" + name + "_checkpoint.csv";
    f.checkpoint = ck_path;
    auto& steps = f.steps;
    if (fs::exists(ck_path) && fs::exists(ck_rows)) {
      const ns::CheckpointReader ck(ck_path);
      const auto it = ck.header().text.find("key");
      if (it != ck.header().text.end() && it->second == key) {
        const auto& v = ck.header().values;
        // The fine box the state was computed on (a checkpoint written before re-plans existed: the planned one).
        ns::FineBoxShift shift;
        for (int d = 0; d < 3; ++d) {
          const auto lo = v.find(fmt::format("shift_lo{}", d)), hi = v.find(fmt::format("shift_hi{}", d));
          if (lo != v.end()) shift.lo[std::size_t(d)] = int(std::lround(lo->second));
          if (hi != v.end()) shift.hi[std::size_t(d)] = int(std::lround(hi->second));
        }
        // The wings' phase (a flight with the frequency as an actuator; absent before it existed: time x frequency).
        std::optional<double> phase;
        if (const auto ph = v.find("phase"); ph != v.end()) phase = ph->second;
        if (const auto rp = ck.header().text.find("replans"); rp != ck.header().text.end()) {
          try {
            f.replans = json::parse(rp->second);
          } catch (const std::exception&) {
            throw InputError(ck_path, "replans", "not a JSON array", "the header flapstab fly wrote");
          }
        }
        // Over ranks each reads its planes only.
        const ns::SimulationState s = ns::read_state_over_ranks(ck, ns::plan_grid(ns::shifted_plan(plan, shift)), D);
        BodyStateVector x;
        Wrench held;
        for (int i = 0; i < 12; ++i) x(i) = v.at(fmt::format("x{}", i));
        for (int i = 0; i < 3; ++i)
          held.force(i) = v.at(fmt::format("F{}", i)), held.moment(i) = v.at(fmt::format("M{}", i));
        std::ifstream in(ck_rows);
        std::string line;
        std::getline(in, line);
        const std::vector<std::string> file_commands = command_columns(line);
        while (std::getline(in, line)) {
          if (line.empty()) continue;
          CfdFlightStep r;
          try {
            r = parse_steps_row(line, file_commands, actuators);
          } catch (const std::exception&) {
            throw InputError(ck_rows, "row", "a malformed row", "the rows flapstab fly wrote with its checkpoint");
          }
          if (r.step <= s.step) steps.push_back(r);
        }
        fl.restore(s, x, held, steps, shift, phase);
        f.resumed = true;
        if (talk)
          fmt::print("  {}: resumed from {} at step {} (t/T = {:.3f})\n", name, ck_path, s.step, s.time / T);
      } else if (talk) {
        fmt::print("  {}: {} is of another case, start or perturbation: starting afresh\n", name, ck_path);
      }
    }
    if (!f.resumed) {
      fl.start(hover, x_init);
      steps.push_back(fl.current());
    }
    const long first = steps.front().step;
    auto checkpoint = [&]() {
      std::map<std::string, double> v;
      const CfdFlightStep& cur = fl.current();
      for (int i = 0; i < 12; ++i) v[fmt::format("x{}", i)] = cur.x(i);
      for (int i = 0; i < 3; ++i)
        v[fmt::format("F{}", i)] = cur.aero.force(i), v[fmt::format("M{}", i)] = cur.aero.moment(i);
      v["phase"] = cur.phase;
      for (int d = 0; d < 3; ++d) {
        v[fmt::format("shift_lo{}", d)] = fl.fine_box_shift().lo[std::size_t(d)];
        v[fmt::format("shift_hi{}", d)] = fl.fine_box_shift().hi[std::size_t(d)];
      }
      ns::from_root(D, [&] {
        fs::create_directories(dir);
        std::string rows = steps_header(actuators);
        for (const auto& s : steps) rows += steps_row(s, T);
        write_file_atomic(ck_rows, rows);
        return std::string();
      });
      // Over ranks rank 0 writes it, taking the slabs one at a time.
      ns::write_state(ck_path, fl.simulation(), v, {{"key", key}, {"replans", f.replans.dump()}});
    };
    const auto tr = std::chrono::steady_clock::now();
    const long start_step = steps.back().step;
    std::size_t replans_seen = 0;
    // The perturbed (or only) flight's flow fields and surfaces, as flapstab cfd writes them ([aero.cfd]
    // fields_per_cycle, surfaces_per_cycle, field_precision; a resumed run appends to the series).
    const bool outputs = name == "flight";
    std::optional<ns::FieldOutput> fields;
    std::optional<ns::SurfaceOutput> surfaces;
    if (outputs) {
      fields.emplace(dir + "/fields", c.aero.cfd.fields_per_cycle,
                     c.aero.cfd.field_precision == "float32" ? ns::FieldPrecision::float32
                                                             : ns::FieldPrecision::float64,
                     c.aero.cfd.field_files == "per-rank");
      surfaces.emplace(dir + "/surfaces", c.aero.cfd.surfaces_per_cycle);
      if (!f.resumed && c.aero.cfd.fields_per_cycle > 0) fields->write(fl.simulation());
      if (!f.resumed && c.aero.cfd.surfaces_per_cycle > 0) surfaces->write(fl.simulation());
    }
    try {
      while (steps.back().step - first < limit) {
        const double t_before = fl.simulation().time();
        const CfdFlightStep s = fl.advance();
        steps.push_back(s);
        for (; replans_seen < fl.replans().size(); ++replans_seen) {
          const CfdReplan& e = fl.replans()[replans_seen];
          f.replans.push_back({{"step", e.step},
                               {"t_s", e.time},
                               {"wingbeat", (e.time - steps.front().time) / T},  // of the flight
                               {"gap_m", e.gap},
                               {"shift_cells", {{"lo", e.shift.lo}, {"hi", e.shift.hi}}},
                               {"fine_box_m", {{e.fine_lo.x(), e.fine_lo.y(), e.fine_lo.z()},
                                               {e.fine_hi.x(), e.fine_hi.y(), e.fine_hi.z()}}},
                               {"cells", e.cells},
                               {"seconds", e.seconds}});
          if (talk) {
            fmt::print("  {}: the fine box re-planned at wingbeat {:.3f} (a part came within {:.3g} mm of its "
                       "face): now [{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] m, {} cells, the flow "
                       "carried over in {:.1f} s\n",
                       name, (e.time - steps.front().time) / T, e.gap * 1e3, e.fine_lo.x(), e.fine_hi.x(),
                       e.fine_lo.y(), e.fine_hi.y(), e.fine_lo.z(), e.fine_hi.z(), e.cells, e.seconds);
            std::fflush(stdout);
          }
        }
        if (outputs) {
          ns::StepReport rep;
          rep.t_before = t_before;
          rep.time = s.time;
          rep.step = s.step;
          fields->on_step(fl.simulation(), rep);
          surfaces->on_step(fl.simulation(), rep);
        }
        const long done = s.step - first;
        if (std::abs(s.x(10)) > max_angle || std::abs(s.x(9)) > max_angle) {
          f.stop = fmt::format("the attitude left the envelope (|theta| or |phi| > {:g} deg) at t/T = {:.3f}",
                               max_angle * 180 / M_PI, s.time / T);
          break;
        }
        if (done % spc == 0 || done == limit) {
          checkpoint();
          if (talk) {
            const double el = seconds_since(tr), rate = el / double(s.step - start_step);
            std::string cmd;
            if (fl.closed_loop())
              for (std::size_t a = 0; a < actuators.size() && a < s.command.size(); ++a)
                cmd += fmt::format(", command {} {:+.3f}", actuators[a].label(), s.command[a]);
            fmt::print("  {} wingbeat {:.4g}/{:g}: theta {:+.3f} deg, q {:+.2f} deg/s, (x, z) ({:+.3f}, {:+.3f}) mm{}; "
                       "{:.0f} s, about {:.0f} s left{}\n",
                       name, double(done) / spc, wingbeats, s.x(10) * 180 / M_PI, s.x(7) * 180 / M_PI, s.x(0) * 1e3,
                       s.x(2) * 1e3, cmd, seconds_since(t0), rate * double(limit - done),
                       with_reference && name == "reference" ? " (then the perturbed flight)" : "");
            std::fflush(stdout);  // progress of a long run, also when stdout is a file
          }
        }
        // Over ranks a signal may reach the ranks at different steps: they stop together at the first step any saw it.
        if (const int sig = ranks ? int(D.max(interrupt_requested())) : interrupt_requested(); sig != 0) {
          checkpoint();
          clear_interrupt();
          throw Interrupted(sig, fmt::format("free flight stopped on {} at step {} (t/T = {:.4f}); {} is written: "
                                             "the same command continues",
                                             signal_name(sig), s.step, s.time / T, ck_path));
        }
      }
    } catch (const BodyLeftGrid& e) {
      checkpoint();
      throw SolveError(fmt::format("{} ({} flight; checkpoint {} written)", e.what(), name, ck_path));
    } catch (const ns::StepFailure& e) {
      throw SolveError(fmt::format("free flight: the flow diverged at step {} (t/T = {:.4f}) of the {} flight: {}; "
                                   "the last checkpoint is {}",
                                   e.step(), e.time() / T, name, e.why(), ck_path));
    }
    f.wall_s = seconds_since(tr);
    return f;
  };

  if (with_reference) ref_flight = fly(BodyStateVector::Zero(), "reference", total);
  // A reference that left the attitude envelope ends there: the deviation (and a controller's sensed signal) is not
  // defined beyond it, so the perturbed flight stops at the same step.
  long main_limit = total;
  std::string cut;
  if (ref_flight && !ref_flight->stop.empty()) {
    main_limit = ref_flight->steps.back().step - ref_flight->steps.front().step;
    cut = fmt::format("the unperturbed reference flight stopped ({}): the perturbed flight ends at the same step",
                      ref_flight->stop);
    if (talk) fmt::print("  {}\n", cut);
  }
  const Flown main = fly(x0, "flight", main_limit);
  const std::vector<CfdFlightStep>& steps = main.steps;
  const long first = steps.front().step;
  const bool resumed = main.resumed;
  const std::string ck_path = main.checkpoint;
  FlightResult r;
  const std::string stop = !main.stop.empty() ? main.stop : cut;

  // The phase-locked samples for the trajectory and the growth estimate. The reference: the unperturbed coupled
  // flight at the same step (with a perturbation from the hover), else the tethered hover (the body at rest at O).
  std::map<long, BodyStateVector> ref_state;
  if (ref_flight)
    for (const auto& s : ref_flight->steps) ref_state[s.step - ref_flight->steps.front().step] = s.x;
  auto reference_at = [&](long k) {
    const auto it = ref_state.find(k);
    return it == ref_state.end() ? BodyStateVector::Zero().eval() : it->second;
  };
  std::vector<double> sample_cfl;  // the CFL number of each sample's step
  for (const auto& s : steps)
    if ((s.step - first) % stride == 0) {
      FlightSample q;
      q.t = s.time - steps.front().time;
      q.x = s.x;
      q.aero = s.aero;
      q.power = s.power;
      q.command = s.command;
      r.samples.push_back(q);
      sample_cfl.push_back(s.cfl);
    }
  r.completed = stop.empty();
  r.stop_reason = stop;
  r.steps = steps.back().step - first;
  r.wall_time_s = main.wall_s + (ref_flight ? ref_flight->wall_s : 0);
  const double dt_step = T / spc;
  const ReferenceOrbit reference{[&](double t) { return reference_at(std::lround(t / dt_step)); },
                                 BodyStateVector::Zero()};
  const ReferenceQuantities ref = reference_quantities(c.insect, kin, c.fluid);
  const GrowthEstimate growth = wingbeat_growth(r, reference, ref, T, moving);

  std::string csv = "t_s,wingbeat";
  for (int i = 0; i < 12; ++i) csv += fmt::format(",{}", state_column(i));
  for (int i : {3, 4, 5, 6, 7, 8, 9, 10}) csv += fmt::format(",d{}", state_column(i));
  csv += ",X_N,Y_N,Z_N,L_N_m,M_N_m,N_N_m,power_W";
  for (const auto& a : actuators) csv += fmt::format(",command_{}", a.label());
  csv += ",cfl\n";
  for (std::size_t n = 0; n < r.samples.size(); ++n) {
    const FlightSample& s = r.samples[n];
    std::vector<double> row{s.t, s.t / T};
    for (int i = 0; i < 12; ++i) row.push_back(s.x(i));
    const BodyStateVector d = s.x - reference.state(s.t);
    for (int i : {3, 4, 5, 6, 7, 8, 9, 10}) row.push_back(d(i));
    for (int i = 0; i < 3; ++i) row.push_back(s.aero.force(i));
    for (int i = 0; i < 3; ++i) row.push_back(s.aero.moment(i));
    row.push_back(s.power);
    for (std::size_t a = 0; a < actuators.size(); ++a) row.push_back(a < s.command.size() ? s.command[a] : 0.0);
    row.push_back(sample_cfl[n]);
    csv += fmt::format("{:.10g}\n", fmt::join(row, ","));
  }
  std::string steps_csv = steps_header(actuators);
  for (const auto& s : steps) steps_csv += steps_row(s, T);

  json j = metadata_json(c, "fly");
  j["flight"] = {{"dof", dof_set_name(dofs)},
                 {"wingbeats", wingbeats},
                 {"start", c.flight.start},
                 {"start_flow", from_hover ? "the kept periodic hover of the Navier-Stokes model (tethered: body at rest at O)"
                                           : "fluid at rest"},
                 {"samples_per_wingbeat", spc / stride},
                 {"period_s", T},
                 {"kinematics", trim.model_runs > 1 ? "the quasi-steady trim refined on the CFD cycle means"
                                                    : "the quasi-steady trim (the CFD trim refinement: [aero.cfd] trim_iterations)"},
                 {"trim_residual_force", trim.relative_force_residual},
                 {"trim_residual_moment", trim.relative_moment_residual},
                 {"initial_state", json::object()},
                 {"cfd_residual", c.flight.cfd_residual},
                 {"hover_residual", {{"force_N", {residual.force.x(), residual.force.y(), residual.force.z()}},
                                     {"moment_N_m", {residual.moment.x(), residual.moment.y(), residual.moment.z()}},
                                     {"note", "the tethered CFD hover's last-wingbeat mean wrench with the weight and "
                                              "buoyancy, body axes, about O; with cfd_residual = \"cancel\" its "
                                              "negative acts on the body as a constant wrench"}}},
                 {"coupling", "explicit: the body's equations integrated over each fluid step with the fluid wrench of "
                              "the step's start held (classical Runge-Kutta, 2 sub-steps to each stage time); grid fixed "
                              "in space (still air); buoyancy of the closed parts added"},
                 {"controller", controller.empty() ? json(nullptr)
                                                   : json{{"description", controller.description},
                                                          {"update", c.control.update},
                                                          {"senses", ref_flight && !closed_reference
                                                                         ? "the deviation from the unperturbed flight"
                                                                         : "the deviation from the tethered hover"},
                                                          {"reference_flight", !ref_flight ? "none"
                                                                               : closed_reference ? "closed loop"
                                                                                                  : "open loop"}}},
                 {"cfd_reference", c.flight.cfd_reference}};
  if (!c.flight.mode.empty()) {
    j["flight"]["mode"] = c.flight.mode;
    j["flight"]["mode_amplitude_nd"] = c.flight.mode_amplitude;
    j["flight"]["mode_multiplier"] = {mode_multiplier.real(), mode_multiplier.imag()};
    j["flight"]["mode_model"] = "quasi-steady (its cyclic trim's Floquet analysis)";
  }
  for (int i = 0; i < 12; ++i)
    j["flight"]["initial_state"][body_state_names()[std::size_t(i)] + "_" + body_state_units()[std::size_t(i)]] = x0(i);
  j["cfd"] = {{"cells", ns::plan_grid(plan).cells()},
              {"cells_per_chord", plan.chord_cells},
              {"steps_per_wingbeat", spc},
              {"reynolds", plan.reynolds},
              {"loads", c.aero.cfd.loads},
              {"fine_box_m", {{plan.fine_lo.x(), plan.fine_lo.y(), plan.fine_lo.z()},
                              {plan.fine_hi.x(), plan.fine_hi.y(), plan.fine_hi.z()}}},
              {"mpi_ranks", D.size()},
              {"replanning", c.flight.cfd_replan},
              {"replans", {{"flight", main.replans}, {"reference", ref_flight ? ref_flight->replans : json::array()}}},
              {"replans_note", "the fine box re-planned around the body when a part came within half the room "
                               "(fine_margin_R) of its faces: step, time, the parts' distance to the old box, the "
                               "shift of each face in fine cells, the new fine box (m), its cells, the wall time"}};
  if (const auto* h = model->hover_record()) {
    json cyc = json::array();
    for (const auto& q : h->cycles) cyc.push_back({{"lift_N", -q.mean.force.z()}, {"change", q.change}});
    j["cfd"]["hover"] = {{"wingbeats", h->cycles.size()}, {"converged", h->converged}, {"reused", h->reused},
                         {"cycles", cyc}};
  }
  j["result"] = {{"completed", r.completed},
                 {"stop_reason", r.stop_reason},
                 {"steps", r.steps},
                 {"resumed", resumed},
                 {"simulation_time_s", r.wall_time_s},
                 {"reference", !ref_flight ? "the tethered hover (body at rest at O)"
                               : closed_reference
                                   ? "the unperturbed coupled flight from the same hover state under the same "
                                     "controller (reference_checkpoint.*)"
                                   : "the unperturbed coupled flight from the same hover state "
                                     "(reference_checkpoint.*)"},
                 {"deviation_note", "largest non-dimensional deviation from the reference within each wingbeat "
                                    "(velocities / U, rates c / U, angles rad) over the moving states"}};
  put_growth(j["result"], growth);
  j["wall_time_s"] = seconds_since(t0);
  LinePlot plot;
  plot.title = c.insect.name + ": free flight coupled to the Navier-Stokes solver (" + dof_set_name(dofs) + ")";
  plot.xlabel = "time (wingbeats)";
  plot.ylabel = ref_flight ? "deviation from the unperturbed flight" : "state";
  Series th{"pitch theta (deg)", {}, {}}, zz{"z (mm, down)", {}, {}}, tr{"pitch theta, unperturbed (deg)", {}, {}};
  for (const FlightSample& s : r.samples) {
    const BodyStateVector d = s.x - reference.state(s.t);
    th.x.push_back(s.t / T);
    th.y.push_back(d(10) * 180 / M_PI);
    zz.x.push_back(s.t / T);
    zz.y.push_back(d(2) * 1e3);
    if (ref_flight) {
      tr.x.push_back(s.t / T);
      tr.y.push_back(reference.state(s.t)(10) * 180 / M_PI);
    }
  }
  plot.series = {th, zz};
  if (ref_flight) plot.series.push_back(tr);
  if (!controller.empty() && !actuators.empty()) {
    Series cm{"command: " + actuators[0].label() + " offset", {}, {}};
    for (const FlightSample& s : r.samples)
      if (!s.command.empty()) {
        cm.x.push_back(s.t / T);
        cm.y.push_back(s.command[0]);
      }
    plot.series.push_back(cm);
  }
  std::string why;
  const auto svg = render_svg(plot, why);
  if (!svg) j["figure_notice"] = why;
  std::vector<std::pair<std::string, std::string>> out = {{dir + "/trajectory.csv", csv},
                                                          {dir + "/steps.csv", steps_csv},
                                                          {dir + "/run.json", j.dump(2) + "\n"}};
  if (svg) out.emplace_back(dir + "/response.svg", *svg);
  ns::from_root(D, [&] {
    write_files_atomic(out);
    return std::string();
  });
  if (talk) {
    if (!r.completed) fmt::print("  stopped: {}\n", r.stop_reason);
    fmt::print("{}", growth_lines(growth, ref_flight ? "unperturbed flight" : "tethered hover"));
    fmt::print("wrote {}/trajectory.csv, steps.csv, run.json{} in {:.1f} s ({} is kept: a larger --wingbeats "
               "continues from it)\n",
               dir, svg ? ", response.svg" : "", seconds_since(t0), ck_path);
  }
  return 0;
}

}  // namespace flapstab
