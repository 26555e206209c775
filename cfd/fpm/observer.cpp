// Force partitioning during a CFD run (observer.hpp).
#include "cfd/fpm/observer.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include "cfd/navier_stokes/plan.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"

namespace flapstab::fpm {

namespace {

constexpr const char* kComponents[7] = {"Fx", "Fy", "Fz", "Mx", "My", "Mz", "power"};
constexpr const char* kUnits[7] = {"N", "N", "N", "N m", "N m", "N m", "W"};
constexpr int kFixedColumns = 17;  // time .. pressure_forced

// A part's index among the `count` parts of the geometry (3, or 5 with a hind pair).
int part_index(const std::string& name, int count = ns::max_parts) {
  for (int i = 0; i < count; ++i)
    if (name == ns::part_names[i]) return i;
  throw std::invalid_argument("unknown part \"" + name + "\"");
}

}  // namespace

const char* component_name(int k) {
  if (k < 0 || k > power_component) throw std::invalid_argument("load component " + std::to_string(k));
  return kComponents[k];
}

int component_index(const std::string& name) {
  for (int k = 0; k <= power_component; ++k)
    if (name == kComponents[k]) return k;
  throw std::invalid_argument("unknown load component \"" + name + "\" (Fx Fy Fz Mx My Mz power)");
}

std::string fpm_csv_header(const std::vector<std::string>& region_names) {
  std::string h =
      "time_s,step,phase,part,component,unit,pressure,kinematic,added_mass,centripetal,vortex,viscous,outer,sum,"
      "solver_pressure,solver_viscous,pressure_forced";
  for (const auto& r : region_names) h += ",vortex." + r;
  return h;
}

std::string fpm_csv_row(const FpmRow& r) {
  std::string s = fmt::format("{:.17g},{},{:.17g},{},{},{}", r.time, r.step, r.phase, ns::part_names[r.part],
                              component_name(r.component), kUnits[r.component]);
  for (double v : {r.pressure, r.kinematic, r.added_mass(), r.centripetal, r.vortex, r.viscous, r.outer, r.sum(),
                   r.solver_pressure, r.solver_viscous, r.pressure_forced})
    s += fmt::format(",{:.17g}", v);
  for (double v : r.regions) s += fmt::format(",{:.17g}", v);
  return s;
}

FpmRow parse_fpm_csv_row(const std::string& line, std::size_t regions) {
  std::vector<std::string> f;
  std::stringstream ss(line);
  for (std::string item; std::getline(ss, item, ',');) f.push_back(item);
  if (f.size() != kFixedColumns + regions)
    throw std::invalid_argument(fmt::format("{} columns where {} belong", f.size(), kFixedColumns + regions));
  auto num = [&](std::size_t i) {
    std::size_t used = 0;
    const double v = std::stod(f[i], &used);
    if (used != f[i].size()) throw std::invalid_argument("not a number: " + f[i]);
    return v;
  };
  FpmRow r;
  r.time = num(0);
  r.step = std::stol(f[1]);
  r.phase = num(2);
  r.part = part_index(f[3]);
  r.component = component_index(f[4]);
  r.pressure = num(6);
  r.kinematic = num(7);
  r.centripetal = num(9);
  r.vortex = num(10);
  r.viscous = num(11);
  r.outer = num(12);
  r.solver_pressure = num(14);
  r.solver_viscous = num(15);
  r.pressure_forced = num(16);
  for (std::size_t i = 0; i < regions; ++i) r.regions.push_back(num(kFixedColumns + i));
  return r;
}

std::size_t fpm_estimated_bytes(const ns::CfdPlan& plan, const FpmSettings& settings) {
  const ns::Grid g = ns::plan_grid(plan);
  const std::size_t field = g.shape().size() * sizeof(double);
  const std::size_t potentials = settings.parts.size() * settings.components.size();
  // level 0 of the Laplacian (3 conductances, diagonal, x, b, r) and its coarse levels (< 1/7 more): 8; its CG work
  // fields 5; the geometry (3 apertures, volume fraction) 4; the Laplacian of u 3, Q 1, the transient centre fields 7
  // and the right-hand side 1; owners and region labels (4 bytes each) 1; the forced-face flags (3 bytes) 1; with the
  // forced region as the body the solver's two kept stage velocities 6 (its faces' u . grad u, 1, takes a centre
  // field's place), and with a sponge layer the predicted velocity of the last stage and a scratch field 4
  const std::size_t stages = settings.body == "forced-region" ? 6 + (plan.sponge_width > 0 ? 4 : 0) : 0;
  return (potentials + 8 + 5 + 4 + 3 + 1 + 7 + 1 + 1 + 1 + stages) * field;
}

void check_fpm_memory(const ns::CfdPlan& plan, const FpmSettings& settings, const std::string& case_path,
                      std::size_t available) {
  if (available == 0) available = ns::available_memory_bytes();
  if (available == 0) return;
  const std::size_t run = ns::estimated_bytes(plan), fpm = fpm_estimated_bytes(plan, settings);
  if (run + fpm <= available) return;
  throw InputError(case_path, "aero.cfd.fpm",
                   fmt::format("the run needs about {:.2f} GiB and force partitioning {:.2f} GiB more ({} potentials); "
                               "{:.2f} GiB of memory is available",
                               run / 1073741824.0, fpm / 1073741824.0, settings.parts.size() * settings.components.size(),
                               available / 1073741824.0),
                   "fewer parts or components in [aero.cfd.fpm] (each potential is one field of the grid), or a "
                   "coarser grid");
}

FpmObserver::FpmObserver(const ns::Simulation& sim, const FpmSettings& settings, std::string directory)
    : settings_(settings), dir_(std::move(directory)) {
  const std::string& file = sim.case_file().path;
  if (!sim.has_bodies())
    throw InputError(file, "aero.cfd.fpm", "force partitioning needs the insect's parts (a body-free run)",
                     "a run with bodies");
  if (sim.motion().rate.squaredNorm() > 0)
    throw InputError(file, "aero.cfd.fpm",
                     "force partitioning is derived for an inertial grid frame; this run's grid turns with the body "
                     "(rates p, q, r)",
                     "a hover or a translating body");
  for (const auto& c : settings.components) components_.push_back(component_index(c));
  for (const auto& p : settings.parts) {
    try {
      parts_.push_back(part_index(p, sim.part_count()));
    } catch (const std::invalid_argument&) {
      throw InputError(file, "aero.cfd.fpm.parts", "\"" + p + "\" is not a part of this insect's geometry",
                       "parts among body, right, left (and hind_right, hind_left with a [hind_wing] pair)");
    }
  }
  for (const auto& r : settings.regions) regions_.push_back(wing_region(r));
  region_size_ = settings.region_size_chords * sim.case_file().insect.wing.mean_chord;
  rho_ = sim.plan().rho;
  FpmOptions opt;
  opt.rtol = settings.tolerance;
  opt.body = settings.body == "forced-region" ? FpmBody::forced_region : FpmBody::surface;
  opt.components.clear();
  for (int k : components_)
    if (k < power_component) opt.components.push_back(k);
  // power rows: from the power potential when "power" is asked for, else from all six components when they are
  power_potential_ = opt.components.size() < components_.size();
  opt.power = power_potential_;
  power_rows_ = power_potential_ || opt.components.size() == 6;
  opt.moment_point = Vec3::Zero();  // O, the grid's origin: the moments of forces.csv
  partition_.emplace(sim.grid(), opt);
  region_names_.push_back("wake");
  for (int i = 1; i < sim.part_count(); ++i)  // the wings, in label_regions' order (sample)
    for (WingRegion r : regions_) region_names_.push_back(std::string(ns::part_names[i]) + "." + region_name(r));
}

void FpmObserver::keep_earlier(const std::string& file, long step) {
  std::ifstream in(file);
  if (!in)
    throw InputError(file, "", "missing or unreadable: a restart from step " + std::to_string(step) +
                                   " needs the force partition of the interrupted run up to that step",
                     "the fpm.csv of the interrupted run");
  std::string line;
  long number = 0;
  const std::string header = fpm_csv_header(region_names_);
  while (std::getline(in, line)) {
    ++number;
    if (number == 1) {
      if (line != header)
        throw InputError(file, "line 1", "other columns than this run's [aero.cfd.fpm] writes",
                         "the header " + header +
                             " (the interrupted run's settings; an fpm.csv written by a flapstab from before "
                             "2026-12-07 lacks its pressure_forced column and cannot be continued)");
      continue;
    }
    FpmRow r;
    try {
      r = parse_fpm_csv_row(line, region_names_.size());
    } catch (const std::exception&) {
      break;  // a row cut by the kill: rows past the checkpoint are dropped anyway
    }
    if (r.step > step) break;
    rows_.push_back(r);
    lines_.push_back(line + "\n");
  }
}

void FpmObserver::on_step(const ns::Simulation& sim, const ns::StepReport& r) {
  const double T = sim.plan().period;
  const bool fields = ns::crossed(settings_.fields_per_cycle, T, r.t_before, r.time) && !dir_.empty();
  if (ns::crossed(settings_.samples_per_cycle, T, r.t_before, r.time) || fields) sample(sim);
  else partition_->record_boundary(sim.solver());
  if (fields) write_fields(sim);
}

std::vector<FpmRow> FpmObserver::sample(const ns::Simulation& sim) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  const std::vector<ns::PartState> states = sim.part_states();
  const auto& reports = partition_->update(*sim.immersed(), states);
  for (const auto& rep : reports) {
    ++solves_;
    iterations_ += rep.stats.iterations;
    unconverged_ += rep.stats.converged ? 0 : 1;
    pockets_max_ = std::max(pockets_max_, rep.pocket_cells);
  }
  // regions in the wings' frames at this instant, each wing with its own planform (a hind pair's: [hind_wing])
  const Insect& insect = sim.case_file().insect;
  std::vector<RegionWing> wings;
  for (int i = 1; i < sim.part_count(); ++i)
    wings.push_back({ns::part_names[i], i <= 2 ? &insect.wing : &*insect.hind_wing, states[std::size_t(i)].pose});
  RegionSet set = label_regions(sim.grid(), wings, regions_, region_size_);
  last_labels_ = set.labels;  // for the field output of this sample
  partition_->set_regions(std::move(set.labels), set.count());
  const std::vector<PartPartition> parts = partition_->partition(sim.solver(), states, rho_);
  const ns::CfdLoadRow loads = sim.loads();
  std::vector<FpmRow> out;
  auto row = [&](int part, int k) {
    FpmRow r;
    r.time = loads.time;
    r.step = sim.step();
    r.phase = loads.phase;
    r.part = part;
    r.component = k;
    return r;
  };
  for (int i : parts_) {
    const PartPartition& P = parts[std::size_t(i)];
    const auto& L = loads.part[i];
    for (int k : components_) {
      if (k == power_component) continue;  // below
      FpmRow r = row(i, k);
      r.pressure = P.pressure[k];
      r.pressure_forced = P.pressure_forced[k];
      r.kinematic = P.kinematic[k];
      r.centripetal = P.centripetal[k];
      r.vortex = P.vortex[k];
      r.viscous = P.viscous[k];
      r.outer = P.outer[k];
      r.solver_pressure = k < 3 ? L.pressure_force[k] : L.pressure_moment[k - 3];
      r.solver_viscous = k < 3 ? L.viscous_force[k] : L.viscous_moment[k - 3];
      for (const Vec6& v : P.vortex_regions) r.regions.push_back(v[k]);
      out.push_back(r);
    }
    if (power_rows_) {  // the part's rate of work on the fluid by mechanism
      FpmRow r = row(i, power_component);
      r.pressure = P.power_pressure;
      r.pressure_forced = P.power_pressure_forced;
      r.kinematic = P.power_kinematic;
      const Vec3 v0 = states[std::size_t(i)].velocity.at(Vec3::Zero()), w = states[std::size_t(i)].velocity.omega;
      r.centripetal = power_potential_ ? P.power_centripetal
                                       : -(P.centripetal.head<3>().dot(v0) + P.centripetal.tail<3>().dot(w));
      r.vortex = P.power_vortex;
      r.viscous = P.power_viscous;
      r.outer = P.power_outer;
      const Vec3 Fp = L.pressure_force, Fv = L.viscous_force, Mp = L.pressure_moment, Mv = L.viscous_moment;
      r.solver_pressure = -(Fp.dot(v0) + Mp.dot(w));
      r.solver_viscous = -(Fv.dot(v0) + Mv.dot(w));
      if (power_potential_) r.regions = P.power_vortex_regions;
      else
        for (const Vec6& v : P.vortex_regions) r.regions.push_back(-(v.head<3>().dot(v0) + v.tail<3>().dot(w)));
      out.push_back(r);
    }
  }
  for (const auto& r : out) {
    rows_.push_back(r);
    lines_.push_back(fpm_csv_row(r) + "\n");
  }
  ++samples_;
  last_sample_step_ = sim.step();
  seconds_ += std::chrono::duration<double>(clock::now() - t0).count();
  return out;
}

void FpmObserver::write_fields(const ns::Simulation& sim) {
  if (dir_.empty()) return;
  if (last_sample_step_ != sim.step()) sample(sim);
  if (!writer_) writer_.emplace(dir_ + "/fields", "fpm", ns::rectilinear(sim.grid()), ns::FieldPrecision::float32);
  const Shape s = sim.grid().shape();
  std::vector<std::vector<double>> store;
  std::vector<std::pair<std::string, std::string>> names;
  for (int i : parts_)
    for (int k : components_) {
      const Field& phi = partition_->potential(i, k);
      std::vector<double> v;
      v.reserve(s.cells());
      for (int kk = 1; kk <= s.nz; ++kk)
        for (int j = 1; j <= s.ny; ++j)
          for (int ii = 1; ii <= s.nx; ++ii) v.push_back(phi(ii, j, kk));
      const std::string tag = std::string(ns::part_names[i]) + "_" + component_name(k);
      store.push_back(std::move(v));
      names.emplace_back("potential_" + tag, k < 3 ? "m" : k < 6 ? "m^2" : "m^2/s");
      store.push_back(partition_->vortex_density(i, k));
      names.emplace_back("vortex_force_density_" + tag, k < 3 ? "N/m^3" : k < 6 ? "N/m^2" : "W/m^3");
    }
  // the regions of this sample as labels (0 wake, then region_names order)
  store.emplace_back(last_labels_.begin(), last_labels_.end());
  names.emplace_back("fpm_region", "1");
  std::vector<ns::CellField> fields;
  for (std::size_t n = 0; n < store.size(); ++n)
    fields.push_back(ns::CellField{names[n].first, names[n].second, {ns::CellArray{store[n].data()}}});
  writer_->write(sim.time(), sim.step(), fields);
}

void FpmObserver::flush() const {
  if (dir_.empty()) return;
  std::string text = fpm_csv_header(region_names_) + "\n";
  for (const auto& l : lines_) text += l;
  write_file_atomic(dir_ + "/fpm.csv", text);
}

namespace {

struct Mean {
  double n = 0, pressure = 0, kinematic = 0, centripetal = 0, vortex = 0, viscous = 0, outer = 0, sp = 0, sv = 0;
  double forced = 0;
  std::vector<double> regions;
  void add(const FpmRow& r) {
    ++n;
    pressure += r.pressure, kinematic += r.kinematic, centripetal += r.centripetal, vortex += r.vortex;
    viscous += r.viscous, outer += r.outer, sp += r.solver_pressure, sv += r.solver_viscous;
    forced += r.pressure_forced;
    regions.resize(r.regions.size(), 0.0);
    for (std::size_t i = 0; i < r.regions.size(); ++i) regions[i] += r.regions[i];
  }
  void finish() {
    if (n == 0) return;
    for (double* v : {&pressure, &kinematic, &centripetal, &vortex, &viscous, &outer, &sp, &sv, &forced}) *v /= n;
    for (double& v : regions) v /= n;
  }
};

bool in_window(double t, double from, double to, double period) {
  const double eps = 1e-9 * period;
  return t > from + eps && t <= to + eps;
}

}  // namespace

nlohmann::json FpmObserver::means(double from_s, double to_s, double period, double weight) const {
  nlohmann::json j;
  j["from_s"] = from_s;
  j["to_s"] = to_s;
  j["samples_per_cycle"] = settings_.samples_per_cycle;
  j["region_size_m"] = region_size_;
  j["regions"] = region_names_;
  j["weight_N"] = weight;
  j["body"] = settings_.body;
  j["units"] = "N for Fx Fy Fz, N m for Mx My Mz (about O), W for power; stability axes (z down: lift = -Fz)";
  j["terms"] = "pressure = kinematic + vortex + viscous + outer + pressure_forced (+ discretisation error), "
               "pressure = the pressure force on the body (surface: the parts' cut cells; forced-region: the parts "
               "widened to every face the immersed boundary forces), "
               "pressure_forced = the share of pressure on the faces the immersed boundary forces (0 for "
               "forced-region); "
               "kinematic = added_mass + "
               "centripetal (the centripetal acceleration reaction); solver_pressure, solver_viscous = the run's own "
               "loads (forces.csv)";
  long samples = 0;
  nlohmann::json parts;
  std::vector<int> listed = components_;
  if (power_rows_ && !power_potential_) listed.push_back(power_component);
  for (int i : parts_)
    for (int k : listed) {
      Mean m;
      for (const auto& r : rows_)
        if (r.part == i && r.component == k && in_window(r.time, from_s, to_s, period)) m.add(r);
      m.finish();
      samples = std::max(samples, long(m.n));
      nlohmann::json c = {{"pressure", m.pressure},   {"kinematic", m.kinematic}, {"added_mass", m.kinematic - m.centripetal},
                          {"centripetal", m.centripetal}, {"vortex", m.vortex},   {"viscous", m.viscous},
                          {"outer", m.outer},         {"sum", m.kinematic + m.vortex + m.viscous + m.outer},
                          {"solver_pressure", m.sp},  {"solver_viscous", m.sv}, {"pressure_forced", m.forced}};
      nlohmann::json reg;
      for (std::size_t r = 0; r < m.regions.size() && r < region_names_.size(); ++r) reg[region_names_[r]] = m.regions[r];
      c["vortex_by_region"] = reg;
      parts[ns::part_names[i]][component_name(k)] = c;
    }
  j["samples"] = samples;
  j["parts"] = parts;
  j["cost"] = {{"seconds", seconds_},
               {"samples_this_run", samples_},
               {"mean_potential_iterations", mean_potential_iterations()},
               {"unconverged_solves", unconverged_},
               {"pocket_cells_max", pockets_max_}};
  return j;
}

std::string FpmObserver::summary(double from_s, double to_s, double period) const {
  if (std::find(components_.begin(), components_.end(), 2) == components_.end()) return "";
  Mean m;
  bool any = false;
  for (const auto& r : rows_)
    if (r.part > 0 && r.component == 2 && in_window(r.time, from_s, to_s, period)) {
      m.add(r);
      any = true;
    }
  if (!any) return "";
  m.finish();
  // the adds ran over the partitioned wings' rows (either pair): a sum per sample = mean over rows x wings
  const double w = double(std::count_if(parts_.begin(), parts_.end(), [](int i) { return i > 0; }));
  auto lift = [&](double fz) { return -fz * w; };
  const double L = lift(m.sp + m.sv);
  auto pc = [&](double fz) { return L != 0 ? 100.0 * lift(fz) / L : 0.0; };
  const double closure = m.kinematic + m.vortex + m.viscous + m.outer - m.pressure;
  const bool surface = settings_.body != "forced-region";
  std::string s = fmt::format(
      "  force partition of the wings' lift (-F_z), t = {:.4g} .. {:.4g} s: total {:.4g} N (pressure {:.4g} N, skin "
      "friction {:.4g} N)\n"
      "    kinematic {:.1f} % (added mass {:.1f} %, centripetal acceleration reaction {:.1f} %), vortex-induced {:.1f} %, "
      "viscous {:.1f} %, outer boundary {:.1f} %, skin friction {:.1f} %\n",
      from_s, to_s, L, lift(m.sp), lift(m.sv), pc(m.kinematic), pc(m.kinematic - m.centripetal), pc(m.centripetal),
      pc(m.vortex), pc(m.viscous), pc(m.outer), pc(m.sv));
  if (surface)
    s += fmt::format(
        "    closure: partition sum - cut-cell pressure force = {:.1f} % of the total; the cut-cell pressure on the "
        "faces the immersed boundary forces, which no part accounts for (direct forcing replaces the momentum equation "
        "there), gives {:.1f} %, and against the pressure on the other faces the parts sum to {:+.1f} %\n",
        pc(closure), pc(m.forced), pc(closure + m.forced));
  else
    s += fmt::format("    closure (body = \"forced-region\": the parts widened to the faces the immersed boundary "
                     "forces): partition sum - pressure force on that body = {:.1f} % of the total, {:+.1f} % of that "
                     "force\n",
                     pc(closure), m.pressure != 0 ? 100 * closure / m.pressure : 0.0);
  if (m.pressure != 0 && std::abs(closure) > 0.1 * std::abs(m.pressure)) {
    if (surface)
      s += fmt::format("    warning: the parts sum to {:.0f} % of the cut-cell pressure lift, {:.0f} % of which lies "
                       "on the forced faces: on this grid read the vortex-induced and viscous shares as what the "
                       "velocity field implies, not as a split of the run's lift (docs/theory/force-partitioning.md, "
                       "\"Closure, and where the gap lives\")\n",
                       100 * (closure + m.pressure) / m.pressure, 100 * m.forced / m.pressure);
    else
      s += fmt::format("    warning: the parts sum to {:.0f} % of the pressure lift on the widened body: on this grid "
                       "the shares are not a split of it (docs/theory/force-partitioning.md, \"The forced region as "
                       "the body\")\n",
                       100 * (closure + m.pressure) / m.pressure);
  }
  if (unconverged_ > 0)
    s += fmt::format("    warning: {} potential solves did not converge (tolerance {:g}); their samples are unreliable\n",
                     unconverged_, settings_.tolerance);
  if (!m.regions.empty()) {
    s += "    vortex-induced lift by region:";
    for (std::size_t r = 0; r < m.regions.size() && r < region_names_.size(); ++r)
      s += fmt::format(" {} {:.1f} %{}", region_names_[r], pc(m.regions[r]), r + 1 < m.regions.size() ? "," : "\n");
  }
  return s;
}

}  // namespace flapstab::fpm
