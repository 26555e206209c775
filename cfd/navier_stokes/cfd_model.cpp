// The AeroModel over the CFD solver (cfd_model.hpp).
#include "cfd/navier_stokes/cfd_model.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cfd/fpm/observer.hpp"
#include "cfd/navier_stokes/run.hpp"
#include "cfd/navier_stokes/solver_io.hpp"
#include "core/atomic_write.hpp"
#include "core/errors.hpp"
#include "core/hash.hpp"

namespace flapstab::ns {

namespace fs = std::filesystem;
using clock_type = std::chrono::steady_clock;

namespace {

// What identifies the insect and its kinematics for the runs (exact decimal images of the values).
std::string fingerprint(const Insect& insect, const Kinematics& kin) {
  std::string s = fmt::format("{:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}", insect.total_mass(),
                              insect.wing.length, insect.wing.mean_chord, kin.frequency_hz, kin.stroke_plane,
                              kin.body_angle);
  if (kin.stroke_plane_on_body) s += " stroke-plane-on-body";
  for (Side side : {Side::right, Side::left})
    for (int k = 0; k < 32; ++k) {
      const WingAngleState a = kin.angles(side, kin.period() * k / 32);
      s += fmt::format(" {:.17g} {:.17g} {:.17g}", a.phi, a.theta, a.alpha);
    }
  // A hind pair's wing and angles (appended, so a two-winged insect's fingerprint, and its cached runs, stay as
  // they were).
  if (insect.hind_wing && kin.has_hind) {
    s += fmt::format(" hind {:.17g} {:.17g}", insect.hind_wing->length, insect.hind_wing->mean_chord);
    for (Side side : {Side::right, Side::left})
      for (int k = 0; k < 32; ++k) {
        const WingAngleState a = kin.angles(side, kin.period() * k / 32, Pair::hind);
        s += fmt::format(" {:.17g} {:.17g} {:.17g}", a.phi, a.theta, a.alpha);
      }
  }
  return s;
}

std::string motion_label(const BodyMotion& m) {
  std::string s;
  const char* v[3] = {"u", "v", "w"};
  const char* r[3] = {"p", "q", "r"};
  for (int i = 0; i < 3; ++i)
    if (m.velocity[i] != 0) s += fmt::format("{}{} = {:+.4g} m/s", s.empty() ? "" : ", ", v[i], m.velocity[i]);
  for (int i = 0; i < 3; ++i)
    if (m.rate[i] != 0) s += fmt::format("{}{} = {:+.4g} rad/s", s.empty() ? "" : ", ", r[i], m.rate[i]);
  return s;
}

bool still(const BodyMotion& m) { return m.velocity.squaredNorm() == 0 && m.rate.squaredNorm() == 0; }

CfdLoadRow combine(const CfdLoadRow& a, const CfdLoadRow& b, double sign) {
  CfdLoadRow r = a;
  r.parts = std::max(a.parts, b.parts);  // a default (zero) row has 3 parts; the hind pair's are zero there
  for (int i = 0; i < max_parts; ++i) {
    r.part[i].pressure_force += sign * b.part[i].pressure_force;
    r.part[i].viscous_force += sign * b.part[i].viscous_force;
    r.part[i].pressure_moment += sign * b.part[i].pressure_moment;
    r.part[i].viscous_moment += sign * b.part[i].viscous_moment;
    r.part[i].power += sign * b.part[i].power;
  }
  r.wing_power += sign * b.wing_power;
  return r;
}

WrenchSample sample_of(const CfdLoadRow& row) {
  WrenchSample w;
  w.body = row.part[0].wrench();
  w.right = row.part[1].wrench();
  w.left = row.part[2].wrench();
  // A hind wing's loads join those of the fore wing on its side, as in the quasi-steady model.
  if (row.parts == max_parts) {
    w.right += row.part[3].wrench();
    w.left += row.part[4].wrench();
  }
  w.power = row.wing_power;
  return w;
}

// A wingbeat of n phase-locked rows (row i at phase i / n, i = 1..n) as a periodic history of `samples` samples
// from phase 0 (linear interpolation when samples != n).
WrenchHistory history_from_rows(const std::vector<CfdLoadRow>& rows, double T, int samples) {
  const int n = int(rows.size());
  if (n < 2) throw SolveError("cfd model: a wingbeat without loads");
  if (samples <= 0) samples = n;
  auto at = [&](int i) { return sample_of(rows[std::size_t(((i % n) + n - 1) % n)]); };  // sample at phase i / n
  WrenchHistory h;
  for (int j = 0; j < samples; ++j) {
    const double x = double(j) * n / samples;
    const int i = int(std::floor(x));
    const double f = x - i;
    const WrenchSample a = at(i), b = at(i + 1);
    WrenchSample w;
    w.body = Wrench{(1 - f) * a.body.force + f * b.body.force, (1 - f) * a.body.moment + f * b.body.moment};
    w.right = Wrench{(1 - f) * a.right.force + f * b.right.force, (1 - f) * a.right.moment + f * b.right.moment};
    w.left = Wrench{(1 - f) * a.left.force + f * b.left.force, (1 - f) * a.left.moment + f * b.left.moment};
    w.power = (1 - f) * a.power + f * b.power;
    w.time = T * j / samples;
    h.samples.push_back(w);
  }
  return h;
}

Wrench mean_of(const std::vector<CfdLoadRow>& rows) {
  Wrench s;
  for (const auto& r : rows) s += r.total();
  return Wrench{s.force / double(rows.size()), s.moment / double(rows.size())};
}

nlohmann::json rows_json(const std::vector<CfdLoadRow>& rows) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& r : rows) {
    std::string line = forces_csv_row(r);
    line.pop_back();
    a.push_back(line);
  }
  return a;
}

std::vector<CfdLoadRow> rows_from(const nlohmann::json& a) {
  std::vector<CfdLoadRow> rows;
  for (const auto& l : a) rows.push_back(parse_forces_csv_row(l.get<std::string>()));
  return rows;
}

nlohmann::json cycles_json(const std::vector<CycleRecord>& cycles) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& c : cycles)
    a.push_back({{"cycle", c.cycle},
                 {"mean_force_N", {c.mean.force.x(), c.mean.force.y(), c.mean.force.z()}},
                 {"mean_moment_N_m", {c.mean.moment.x(), c.mean.moment.y(), c.mean.moment.z()}},
                 {"change", c.change},
                 {"drift", c.drift}});
  return a;
}

std::vector<CycleRecord> cycles_from(const nlohmann::json& a) {
  std::vector<CycleRecord> out;
  for (const auto& c : a) {
    CycleRecord r;
    r.cycle = c.at("cycle").get<int>();
    for (int i = 0; i < 3; ++i) {
      r.mean.force[i] = c.at("mean_force_N").at(std::size_t(i)).get<double>();
      r.mean.moment[i] = c.at("mean_moment_N_m").at(std::size_t(i)).get<double>();
    }
    r.change = c.at("change").get<double>();
    r.drift = c.value("drift", -1.0);  // absent in caches written before it was computed
    out.push_back(r);
  }
  return out;
}

// The partition's means over the samples with from_s < t <= to_s (half a step of slack at both ends: the samples
// are taken at step ends), summed over the partitioned parts; the load components only (not "power").
PartitionMeans partition_means(const fpm::FpmObserver& obs, double from_s, double to_s, double dt) {
  PartitionMeans m;
  m.body = obs.settings().body;
  for (int k : obs.components())
    if (k < fpm::power_component) m.components.push_back(k);
  m.values.assign(m.components.size(), {});
  std::vector<double> times;
  for (const auto& r : obs.rows()) {
    if (!(r.time > from_s + 0.5 * dt && r.time <= to_s + 0.5 * dt)) continue;
    const auto it = std::find(m.components.begin(), m.components.end(), r.component);
    if (it == m.components.end()) continue;
    auto& v = m.values[std::size_t(it - m.components.begin())];
    v[PartitionMeans::pressure] += r.pressure;
    v[PartitionMeans::kinematic] += r.kinematic;
    v[PartitionMeans::centripetal] += r.centripetal;
    v[PartitionMeans::vortex] += r.vortex;
    v[PartitionMeans::viscous] += r.viscous;
    v[PartitionMeans::outer] += r.outer;
    v[PartitionMeans::run_pressure] += r.solver_pressure;
    v[PartitionMeans::run_friction] += r.solver_viscous;
    v[PartitionMeans::pressure_forced] += r.pressure_forced;
    if (std::find(times.begin(), times.end(), r.time) == times.end()) times.push_back(r.time);
  }
  if (times.empty()) throw SolveError("cfd model: a wingbeat without force-partition samples");
  for (auto& v : m.values)
    for (double& x : v) x /= double(times.size());
  return m;
}

// a + sign b, term by term (the same components).
PartitionMeans combine(const PartitionMeans& a, const PartitionMeans& b, double sign) {
  if (a.components != b.components) throw SolveError("cfd model: force partitions of different components");
  PartitionMeans r = a;
  for (std::size_t i = 0; i < r.values.size(); ++i)
    for (int t = 0; t < PartitionMeans::terms; ++t) r.values[i][std::size_t(t)] += sign * b.values[i][std::size_t(t)];
  return r;
}

nlohmann::json partition_json(const PartitionMeans& m) {
  nlohmann::json names = nlohmann::json::array();
  for (int t = 0; t < PartitionMeans::terms; ++t) names.push_back(PartitionMeans::term_name(t));
  return {{"definition", PartitionMeans::definition},
          {"body", m.body},
          {"components", m.components},
          {"terms", names},
          {"values", m.values}};
}

// A cached partition, or none where it was cached under another definition or body (its run's split by mechanism is
// then left out, as for a run without partitioning).
std::optional<PartitionMeans> partition_from(const nlohmann::json& j, const std::string& body) {
  if (j.value("definition", 1) != PartitionMeans::definition || j.value("body", "") != body) return std::nullopt;
  PartitionMeans m;
  m.body = body;
  m.components = j.at("components").get<std::vector<int>>();
  m.values = j.at("values").get<std::vector<std::array<double, PartitionMeans::terms>>>();
  if (m.values.size() != m.components.size()) throw SolveError("cfd model: a damaged force partition in the run cache");
  return m;
}

// Per wingbeat (null where a wingbeat was not partitioned).
nlohmann::json partitions_json(const std::vector<std::optional<PartitionMeans>>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& m : v) a.push_back(m ? partition_json(*m) : nlohmann::json());
  return a;
}

// `count` wingbeats from the "partition" array of a cache file (absent, short or null entries: not partitioned).
std::vector<std::optional<PartitionMeans>> partitions_from(const nlohmann::json& j, std::size_t count,
                                                           const std::string& body) {
  std::vector<std::optional<PartitionMeans>> v(count);
  if (!j.contains("partition")) return v;
  const auto& a = j.at("partition");
  for (std::size_t i = 0; i < count && i < a.size(); ++i)
    if (!a[i].is_null()) v[i] = partition_from(a[i], body);
  return v;
}

// Locks `path` (a campaign's claim on the hover, a run or the continued hover), waiting while another process holds it
// and saying so.
template <class Say>
void claim(std::optional<FileLock>& lock, const std::string& path, const std::string& what, const Say& say) {
  lock.emplace(path, FileLock::Mode::try_only);
  if (lock->held()) return;
  say(fmt::format("cfd model: waiting for {}, which another process is making ({}: {})\n", what, path,
                  FileLock::holder(path)));
  lock.emplace(path, FileLock::Mode::wait);
}

std::optional<nlohmann::json> read_json(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  try {
    nlohmann::json j = nlohmann::json::parse(in);
    if (j.value("key", std::string()) != key) return std::nullopt;
    return j;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}


// The ranks the model's flows run over (CfdModel::run_over): rank 0 reads and writes the cache and holds its file
// locks for them all and tells the others what it found (from_root), so that every rank makes the same decisions and
// meets the same collective operations; a state kept in the cache is the whole grid's, which every rank reads.
struct Ranks {
  std::shared_ptr<const Decomposition> d;  // never null (one rank without MPI by default)
  template <class Fn>
  void on_lead(Fn&& fn) const {
    on_root(*d, std::forward<Fn>(fn));
  }
  std::optional<nlohmann::json> json(const std::string& path, const std::string& key) const {
    const std::string text = from_root(*d, [&] {
      const auto j = read_json(path, key);
      return j ? j->dump() : std::string();
    });
    if (text.empty()) return std::nullopt;
    return nlohmann::json::parse(text);
  }
  bool exists(const std::string& path) const {
    return from_root(*d, [&] { return std::string(fs::exists(path) ? "1" : ""); }) == "1";
  }
  // claim() on rank 0, the others waiting (without spinning) until it holds the lock.
  template <class Say>
  void claim(std::optional<FileLock>& lock, const std::string& path, const std::string& what, const Say& say) const {
    from_root(*d, [&] {
      ::flapstab::ns::claim(lock, path, what, say);
      return std::string();
    });
  }
  // The lock taken without waiting: nothing when rank 0 now holds it, else who does (FileLock::holder).
  std::optional<std::string> try_claim(std::optional<FileLock>& lock, const std::string& path) const {
    const std::string answer = from_root(*d, [&] {
      lock.emplace(path, FileLock::Mode::try_only);
      return lock->held() ? std::string() : "-" + FileLock::holder(path);  // never empty when another holds it
    });
    if (answer.empty()) return std::nullopt;
    return answer.substr(1);
  }
  // A kept (whole-grid) state of grid `whole` read back: over ranks only this rank's planes.
  SimulationState read(const CheckpointReader& ck, const Grid& whole) const {
    return read_state_over_ranks(ck, whole, *d);
  }
  SimulationOptions options(SimulationOptions o = {}) const {
    if (d->distributed()) o.decomposition = d;
    return o;
  }
};

// A run under way keeps its state after its last whole wingbeat (h5) and what it has measured so far (json, with
// `key` and `step`): read back if both belong to `key` and to each other (a run killed between the two writes gets a
// warning through `say` and starts again), kept after each wingbeat, removed when the run ends.
struct PartialRun {
  std::string json, h5;
  std::optional<std::pair<SimulationState, nlohmann::json>> read(const Ranks& ranks, const std::string& key,
                                                                 const Grid& grid,
                                                                 const std::function<void(const std::string&)>& say,
                                                                 const char* restart) const {
    const auto part = ranks.json(json, key);
    if (!part || !ranks.exists(h5)) return std::nullopt;
    const CheckpointReader ck(h5);
    SimulationState saved = ranks.read(ck, grid);
    if (saved.step == part->at("step").get<long>()) return std::make_pair(std::move(saved), *part);
    say(fmt::format("  warning: {} (step {}) and {} (step {}) do not belong together; {}\n", h5, saved.step, json,
                    part->at("step").get<long>(), restart));
    return std::nullopt;
  }
  void keep(const Ranks& ranks, const std::string& key, const Simulation& sim, nlohmann::json measured) const {
    write_state(h5, sim, {}, {{"key", key}});  // over ranks rank 0 writes it, taking the slabs one at a time
    ranks.on_lead([&] {
      measured["key"] = key;
      measured["step"] = sim.step();
      write_file_atomic(json, measured.dump(1) + "\n");
    });
  }
  void remove(const Ranks& ranks) const {
    ranks.on_lead([&] {
      std::error_code ec;
      fs::remove(json, ec);
      fs::remove(h5, ec);
    });
  }
};

}  // namespace

const char* PartitionMeans::term_name(int t) {
  static const char* names[terms] = {"pressure", "kinematic", "centripetal",  "vortex",         "viscous",
                                     "outer",    "run_pressure", "run_friction", "pressure_forced"};
  return t >= 0 && t < terms ? names[t] : "?";
}

struct CfdModel::State {
  std::string key;  // the case file, the base insect and kinematics
  Case base_case;
  Kinematics base_kin;
  std::string base_print;
  CfdPlan plan;
  PeriodicSettings hover_settings, perturbed_settings;
  SimulationState hover_state;
  std::vector<CfdLoadRow> hover_rows;
  std::unique_ptr<Simulation> ref_sim;
  bool ref_on_file = false;  // the reference's cycles came from the cache: its state is read from there when needed
  std::vector<CycleRecord> ref_cycles;
  std::vector<std::vector<CfdLoadRow>> ref_rows;
  std::unique_ptr<fpm::FpmObserver> ref_fpm;       // with [aero.cfd.fpm]: partitions the continued hover
  std::vector<std::optional<PartitionMeans>> ref_partition;  // its wingbeat means, beside ref_cycles
  std::vector<CfdRunRecord> records;
  std::map<std::string, std::vector<CfdLoadRow>> answers;  // differences d of the runs made, by run key
  int runs = 0;
};

CfdModel::CfdModel(Case c, std::ostream* log, std::string cache_directory)
    : case_(std::move(c)), log_(log), cache_(std::move(cache_directory)),
      ranks_(std::make_shared<const Decomposition>()) {}

void CfdModel::run_over(std::shared_ptr<const Decomposition> ranks) {
  if (st_) throw std::logic_error("CfdModel::run_over: call before the first run");
  if (ranks && ranks->distributed() && case_.aero.cfd.fpm.enabled)
    throw InputError(case_.path, "aero.cfd.fpm.enabled",
                     fmt::format("force partitioning runs in one process; the CFD model's flows would run over {} MPI "
                                 "ranks", ranks->size()),
                     "enabled = false, or the analysis without --ranks-per-flow");
  ranks_ = ranks ? std::move(ranks) : std::make_shared<const Decomposition>();
}
CfdModel::~CfdModel() = default;

const std::vector<CfdRunRecord>& CfdModel::records() const {
  static const std::vector<CfdRunRecord> none;
  return st_ ? st_->records : none;
}
const CfdPlan* CfdModel::plan() const { return st_ ? &st_->plan : nullptr; }
const SimulationState* CfdModel::hover_state() const { return st_ ? &st_->hover_state : nullptr; }
const std::vector<CycleRecord>& CfdModel::reference_cycles() const {
  static const std::vector<CycleRecord> none;
  return st_ ? st_->ref_cycles : none;
}

WrenchHistory CfdModel::run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                            const AeroRunOptions& options) const {
  const CfdSettings& s = case_.aero.cfd;
  if (s.steps_per_cycle <= 0)
    throw InputError(case_.path, "aero.cfd.steps_per_cycle",
                     "the CFD model runs periodic wingbeats with a fixed, phase-locked time step; none is set",
                     "steps_per_cycle = N, e.g. 400 (a whole number of steps per wingbeat)");
  auto& self = const_cast<CfdModel&>(*this);
  const Ranks ranks{ranks_};
  const std::string print = fingerprint(insect, kin);
  const std::string hash = case_.path.empty() ? std::string("none") : case_hash(case_.path);
  auto file = [&](const std::string& name) { return cache_ + "/" + name; };
  auto say = [&](const std::string& line) {
    if (log_ && ranks_->rank() == 0) *log_ << line << std::flush;
  };
  const double weight = insect.weight();

  // 1. The base hover, once.
  if (!st_) {
    auto st = std::make_unique<State>();
    st->base_case = case_;
    st->base_case.insect = insect;
    st->base_kin = kin;
    st->base_print = print;
    std::vector<Kinematics> kins{kin};
    kins.insert(kins.end(), plan_for_.begin(), plan_for_.end());
    st->plan = plan_cfd(st->base_case, kins, {BodyMotion{}});
    check_ranks_share_grid(st->plan, ranks_->size(), true, case_.path, "--ranks-per-flow");
    // The key names the grid too: the kinematics the grid is planned for (trim bounds, a controller's range) are
    // not all in the case hash, and a kept state is only valid on its own grid.
    const Shape gs = plan_grid(st->plan).shape();
    st->key = fnv1a64_hex(hash + "|" + print + "|" +
                          fmt::format("{} {} {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {}", gs.nx, gs.ny,
                                      gs.nz, st->plan.fine_lo.x(), st->plan.fine_lo.y(), st->plan.fine_lo.z(),
                                      st->plan.fine_hi.x(), st->plan.fine_hi.y(), st->plan.fine_hi.z(),
                                      st->plan.h_actual, st->plan.steps_per_cycle));
    st->hover_settings = {s.hover_tolerance, std::max({2, s.cycles, options.cycles}), s.max_cycles, weight,
                          weight * insect.wing.mean_chord};
    st->perturbed_settings = {s.perturbation_tolerance, 2, s.max_cycles, weight, weight * insect.wing.mean_chord};
    CfdRunRecord rec;
    rec.label = "hover";
    // Processes sharing the cache (a campaign) make the hover once: the others wait for it and reuse it.
    std::optional<FileLock> hover_lock;
    if (!cache_.empty()) ranks.claim(hover_lock, file("hover.lock"), "the hover", say);
    const auto cached = cache_.empty() ? std::nullopt : ranks.json(file("hover.json"), st->key);
    if (cached && ranks.exists(file("hover.h5"))) {
      const CheckpointReader ck(file("hover.h5"));
      st->hover_state = ranks.read(ck, plan_grid(st->plan));
      st->hover_rows = rows_from(cached->at("last_cycle"));
      rec.cycles = cycles_from(cached->at("cycles"));
      rec.converged = cached->at("converged").get<bool>();
      rec.wall_seconds = cached->at("wall_s").get<double>();
      rec.reused = true;
      say(fmt::format("cfd model: hover state reused from {} ({} wingbeats)\n", file("hover.h5"), rec.cycles.size()));
    } else {
      const CfdPlan& p = st->plan;
      say(fmt::format("cfd model: hover from rest, grid {} cells ({:.1f} per mean chord), {} steps per wingbeat, "
                      "{} to {} wingbeats until the cycle-mean loads change by less than {:g} of the weight{}\n",
                      plan_grid(p).cells(), p.chord_cells, p.steps_per_cycle, st->hover_settings.min_cycles,
                      st->hover_settings.max_cycles, st->hover_settings.tolerance,
                      p.sponge_width > 0 ? fmt::format("; sponge layer {:.3g} m deep along the faces", p.sponge_width)
                                         : std::string()));
      Simulation sim(st->base_case, kin, BodyMotion{}, p, ranks.options());
      if (ranks_->distributed())  // each flow of the model over the group's ranks
        say(fmt::format("  every flow over {} MPI ranks: z slabs of {} planes\n", ranks_->size(),
                        slab_planes_text(sim.solver())));
      // A hover interrupted (killed) resumes from its last whole wingbeat: its state and its wingbeats so far are kept
      // after every wingbeat beside hover.h5, and removed when it ends.
      const PartialRun partial{file("hover.partial.json"), file("hover.partial.h5")};
      PeriodicRun earlier;
      if (const auto part = cache_.empty() ? std::nullopt
                                           : partial.read(ranks, st->key, plan_grid(p), say,
                                                          "the hover starts again from rest")) {
        sim.restore(part->first);
        earlier.cycles = cycles_from(part->second.at("cycles"));
        earlier.last_cycle = rows_from(part->second.at("last_cycle"));
        earlier.wall_seconds = part->second.at("wall_s").get<double>();
        say(fmt::format("  hover resumed after its wingbeat {} from {}\n", earlier.cycles.size(), partial.h5));
      }
      auto keep = [&](const PeriodicRun& so_far) {
        if (cache_.empty()) return;
        partial.keep(ranks, st->key, sim,
                     {{"cycles", cycles_json(so_far.cycles)}, {"last_cycle", rows_json(so_far.last_cycle)},
                      {"wall_s", so_far.wall_seconds}});
      };
      PeriodicRun pr;
      try {
        pr = run_until_periodic(sim, st->hover_settings, ranks_->rank() == 0 ? log_ : nullptr, "  hover ",
                                std::move(earlier), keep);
      } catch (const StepFailure& e) {
        throw SolveError(fmt::format("cfd model: the hover from rest diverged at step {} (t/T = {:.4f}): {}; lower the "
                                     "time step (aero.cfd.steps_per_cycle)", e.step(), e.time() / p.period, e.why()));
      }
      st->hover_state = sim.state();
      st->hover_rows = pr.last_cycle;
      rec.cycles = pr.cycles;
      rec.converged = pr.converged;
      rec.wall_seconds = pr.wall_seconds;
      if (!pr.converged)
        say(fmt::format("  warning: the hover did not converge in {} wingbeats (last change {:.3g} of the weight, "
                        "hover_tolerance {:g}); its state is kept and perturbations are measured against its "
                        "continuation\n", pr.cycles.size(), pr.final_change(), st->hover_settings.tolerance));
      if (!cache_.empty()) {
        write_state(file("hover.h5"), sim, {}, {{"key", st->key}});
        ranks.on_lead([&] {
          nlohmann::json j = {{"key", st->key}, {"cycles", cycles_json(pr.cycles)}, {"converged", pr.converged},
                              {"wall_s", pr.wall_seconds}, {"last_cycle", rows_json(pr.last_cycle)}};
          write_file_atomic(file("hover.json"), j.dump(1) + "\n");
        });
        partial.remove(ranks);
      }
    }
    if (!cache_.empty()) {
      if (const auto r = ranks.json(file("reference.json"), st->key)) {
        st->ref_cycles = cycles_from(r->at("cycles"));
        for (const auto& c : r->at("rows")) st->ref_rows.push_back(rows_from(c));
        st->ref_partition = partitions_from(*r, st->ref_cycles.size(), case_.aero.cfd.fpm.body);
        st->ref_on_file = true;
      }
    }
    st->records.push_back(rec);
    self.st_ = std::move(st);
  }
  State& st = *st_;
  const int n = st.plan.steps_per_cycle;
  const bool base_kin = print == st.base_print;
  if (base_kin && still(motion)) return history_from_rows(st.hover_rows, st.plan.period, options.samples_per_cycle);

  // 3. A perturbed run from the kept hover state (or its cached result).
  const std::string label = (motion_label(motion).empty() ? std::string() : motion_label(motion)) +
                            (base_kin ? "" : std::string(still(motion) ? "" : ", ") + "other kinematics");
  const std::string run_key = fnv1a64_hex(st.key + "|" + print + "|" + fmt::format("{:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}",
                                  motion.velocity.x(), motion.velocity.y(), motion.velocity.z(), motion.rate.x(),
                                  motion.rate.y(), motion.rate.z()));
  const std::string run_file = file("run_" + run_key + ".json");
  auto answer_of = [&](const std::vector<CfdLoadRow>& diff) {
    std::vector<CfdLoadRow> answer;
    for (int i = 0; i < n; ++i) answer.push_back(combine(st.hover_rows[std::size_t(i)], diff[std::size_t(i)], +1));
    return history_from_rows(answer, kin.period(), options.samples_per_cycle);
  };
  if (const auto it = st.answers.find(run_key); it != st.answers.end()) return answer_of(it->second);
  CfdRunRecord rec;
  rec.label = label;
  rec.motion = motion;
  rec.other_kinematics = !base_kin;
  std::vector<CfdLoadRow> diff;
  const int number = ++st.runs;
  auto cached = cache_.empty() ? std::nullopt : ranks.json(run_file, run_key);
  // Processes sharing the cache (a campaign) each make the runs no other one holds.
  std::optional<FileLock> run_lock;
  if (!cached && !cache_.empty()) {
    const std::string lock = file("run_" + run_key + ".lock");
    if (options.defer_held) {
      if (const auto holder = ranks.try_claim(run_lock, lock)) {
        --st.runs;
        throw RunHeldElsewhere(fmt::format("cfd model: run {} ({}) is being made by another process ({})", number,
                                           label, *holder));
      }
    } else {
      ranks.claim(run_lock, lock, fmt::format("run {} ({})", number, label), say);
    }
    cached = ranks.json(run_file, run_key);  // finished by another process before the lock was got
  }
  if (cached) {
    rec.cycles = cycles_from(cached->at("cycles"));
    rec.converged = cached->at("converged").get<bool>();
    rec.wall_seconds = cached->at("wall_s").get<double>();
    rec.reused = true;
    diff = rows_from(cached->at("difference"));
    if (cached->contains("partition") && !cached->at("partition").is_null())
      rec.partition = partition_from(cached->at("partition"), case_.aero.cfd.fpm.body);
    say(fmt::format("cfd model: run {} ({}) reused from {}\n", number, label, run_file));
  } else {
    Case c = case_;
    c.insect = insect;
    if (!base_kin) {  // other kinematics must stay within the fine box planned for the base hover
      const CfdPlan q = [&] {
        try {
          return plan_cfd(c, kin, BodyMotion{});
        } catch (const InputError& e) {  // say which run: the case's own kinematics are fine
          // The problem without the file and key the rethrown error names again.
          std::string problem = e.what();
          const std::string prefix = (e.file().empty() ? std::string("input") : e.file()) + ": key '" + e.key() + "': ";
          if (problem.rfind(prefix, 0) == 0) problem.erase(0, prefix.size());
          throw InputError(case_.path, e.key(),
                           fmt::format("the kinematics of CFD run '{}' (asked of the CFD model by the analysis): {}",
                                       label, problem));
        }
      }();
      const double out = std::max((q.swept_hi - st.plan.fine_hi).maxCoeff(), (st.plan.fine_lo - q.swept_lo).maxCoeff());
      if (out > 0)
        throw InputError(case_.path, "aero.cfd.fine_margin_R",
                         fmt::format("kinematics asked of the CFD model sweep {:.3g} m beyond the fine box planned for "
                                     "the base hover", out),
                         "a larger fine_margin_R, so that one grid holds every kinematics of the analysis");
    }
    say(fmt::format("cfd model: run {} ({}) from the kept hover state, until the standard error of its mean difference "
                    "from the continued hover (second half of its wingbeats) is below {:g} of the weight\n",
                    number, label, st.perturbed_settings.tolerance));
    const auto t0 = clock_type::now();
    CfdPlan plan = st.plan;  // the same grid; the time step of these kinematics' wingbeat
    plan.period = kin.period();
    plan.dt = plan.period / plan.steps_per_cycle;
    Simulation sim(c, kin, motion, plan, ranks.options());
    std::vector<std::vector<CfdLoadRow>> history;  // d at every phase, per wingbeat
    // With [aero.cfd.fpm], no body rates (an inertial grid frame) and the base hover's kinematics (the derivative
    // runs; a trim iterate's are not split): the run's partition, per wingbeat.
    const bool partitioned = s.fpm.enabled && motion.rate.squaredNorm() == 0 && base_kin;
    std::unique_ptr<fpm::FpmObserver> obs;
    if (partitioned) obs = std::make_unique<fpm::FpmObserver>(sim, s.fpm, std::string());
    std::vector<std::optional<PartitionMeans>> phist;
    // A run interrupted (killed, or diverged) resumes from its last whole wingbeat: its state and its history so far
    // are kept after every wingbeat beside the run's file, and removed when the run ends.
    const PartialRun partial{file("run_" + run_key + ".partial.json"), file("run_" + run_key + ".partial.h5")};
    double earlier_seconds = 0;
    bool resumed = false;
    if (const auto part = cache_.empty() ? std::nullopt
                                         : partial.read(ranks, run_key, plan_grid(plan), say,
                                                        "the run starts again from the hover")) {
      sim.restore(part->first);
      for (const auto& h : part->second.at("history")) history.push_back(rows_from(h));
      phist = partitions_from(part->second, history.size(), case_.aero.cfd.fpm.body);
      rec.cycles = cycles_from(part->second.at("cycles"));
      earlier_seconds = part->second.at("wall_s").get<double>();
      resumed = true;
      say(fmt::format("  resumed after its wingbeat {} from {}\n", history.size(), partial.h5));
    }
    if (!resumed) {
      sim.restore(st.hover_state, BodyMotion{});
    }
    for (int k = int(history.size()) + 1; k <= st.perturbed_settings.max_cycles; ++k) {
      std::vector<CfdLoadRow> rows;
      const double from = sim.time();
      try {
        for (int i = 0; i < n; ++i) {
          const StepReport r = sim.advance();
          rows.push_back(r.row);
          if (obs) obs->on_step(sim, r);
        }
      } catch (const StepFailure& e) {
        throw SolveError(fmt::format("cfd model: run {} ({}) diverged in its wingbeat {} (step {}): {}; lower the time "
                                     "step (aero.cfd.steps_per_cycle) or the perturbation{}", number, label, k, e.step(),
                                     e.why(), k > 1 && !cache_.empty()
                                                  ? fmt::format(" (its state after wingbeat {} is kept in {})", k - 1, partial.h5)
                                                  : std::string()));
      }
      continue_reference(k);
      phist.resize(std::size_t(k - 1));
      if (obs) phist.push_back(partition_means(*obs, from, sim.time(), plan.dt));
      else phist.emplace_back();
      const auto& ref = st.ref_rows[std::size_t(k - 1)];
      std::vector<CfdLoadRow> dk;
      for (int i = 0; i < n; ++i) dk.push_back(combine(rows[std::size_t(i)], ref[std::size_t(i)], -1));
      history.push_back(dk);
      CycleRecord cr;
      cr.cycle = k;
      cr.mean = mean_of(rows);
      const Wrench d = mean_of(dk);
      // The window: the second half of the wingbeats so far (the start-up of the perturbation left out); its
      // mean difference and the standard error of that mean.
      const int first = k / 2 + 1, count = k - first + 1;
      std::vector<Wrench> window;
      for (int j = first; j <= k; ++j) window.push_back(mean_of(history[std::size_t(j - 1)]));
      const WindowStatistics ws = window_statistics(window, st.perturbed_settings);
      const Wrench& avg = ws.mean;
      cr.change = ws.standard_error;
      cr.drift = ws.drift;
      diff.assign(std::size_t(n), CfdLoadRow{});
      for (int j = first; j <= k; ++j)
        for (int i = 0; i < n; ++i) diff[std::size_t(i)] = combine(diff[std::size_t(i)], history[std::size_t(j - 1)][std::size_t(i)], 1.0 / count);
      for (int i = 0; i < n; ++i) diff[std::size_t(i)].time = rows[std::size_t(i)].time, diff[std::size_t(i)].step = rows[std::size_t(i)].step;
      // The partition's difference over the same window, where this run and the continued hover were partitioned.
      rec.partition.reset();
      bool whole = partitioned;
      for (int j = first; j <= k && whole; ++j)
        whole = phist[std::size_t(j - 1)] && std::size_t(j) <= st.ref_partition.size() &&
                st.ref_partition[std::size_t(j - 1)];
      if (whole) {
        PartitionMeans w = *phist[std::size_t(first - 1)];  // the components; the values summed below
        for (auto& v : w.values) v.fill(0);
        for (int j = first; j <= k; ++j)
          w = combine(w, combine(*phist[std::size_t(j - 1)], *st.ref_partition[std::size_t(j - 1)], -1), 1.0 / count);
        rec.partition = w;
      }
      rec.cycles.push_back(cr);
      say(fmt::format("  wingbeat {:>2}: difference from the hover dF = ({:+.4e}, {:+.4e}, {:+.4e}) N, dM = ({:+.4e}, "
                      "{:+.4e}, {:+.4e}) N m; mean of wingbeats {}-{}: dF = ({:+.4e}, {:+.4e}, {:+.4e}) N, standard "
                      "error {}, drift across it {}\n",
                      k, d.force.x(), d.force.y(), d.force.z(), d.moment.x(), d.moment.y(), d.moment.z(), first, k,
                      avg.force.x(), avg.force.y(), avg.force.z(),
                      cr.change < 0 ? std::string("-") : fmt::format("{:.2e}", cr.change),
                      cr.drift < 0 ? std::string("-") : fmt::format("{:.2e}", cr.drift)));
      if (cr.change >= 0 && cr.change < st.perturbed_settings.tolerance) {
        rec.converged = true;
        break;
      }
      if (!cache_.empty() && k < st.perturbed_settings.max_cycles) {
        nlohmann::json hj = nlohmann::json::array();
        for (const auto& h : history) hj.push_back(rows_json(h));
        partial.keep(ranks, run_key, sim,
                     {{"cycles", cycles_json(rec.cycles)}, {"history", hj}, {"partition", partitions_json(phist)},
                      {"wall_s", earlier_seconds + std::chrono::duration<double>(clock_type::now() - t0).count()}});
      }
    }
    rec.wall_seconds = earlier_seconds + std::chrono::duration<double>(clock_type::now() - t0).count();
    if (!rec.converged)
      say(fmt::format("  warning: run {} did not converge in {} wingbeats (last change {:.3g} of the weight, "
                      "perturbation_tolerance {:g})\n", number, rec.cycles.size(), rec.final_change(),
                      st.perturbed_settings.tolerance));
    say(fmt::format("cfd model: run {} done: {} wingbeats in {:.1f} s\n", number, rec.cycles.size(), rec.wall_seconds));
    if (!cache_.empty()) {
      ranks.on_lead([&] {
        fs::create_directories(cache_);
        nlohmann::json j = {{"key", run_key}, {"label", label}, {"cycles", cycles_json(rec.cycles)},
                            {"converged", rec.converged}, {"wall_s", rec.wall_seconds}, {"difference", rows_json(diff)},
                            {"partition", rec.partition ? partition_json(*rec.partition) : nlohmann::json()}};
        write_file_atomic(run_file, j.dump(1) + "\n");
      });
      partial.remove(ranks);
    }
  }
  st.records.push_back(rec);
  st.answers[run_key] = diff;
  return answer_of(diff);
}


void CfdModel::continue_reference(int k) const {
  State& st = *st_;
  const CfdSettings& s = case_.aero.cfd;
  const int n = st.plan.steps_per_cycle;
  auto file = [&](const std::string& name) { return cache_ + "/" + name; };
  auto say = [&](const std::string& line) {
    if (log_ && ranks_->rank() == 0) *log_ << line << std::flush;
  };
  // The reference at the same wingbeat: one process at a time extends it (a campaign), after taking what the
  // others added.
  const Ranks ranks{ranks_};
  std::optional<FileLock> ref_lock;
  if (int(st.ref_cycles.size()) < k && !cache_.empty()) {
    ranks.claim(ref_lock, file("reference.lock"), "the continued hover", say);
    const auto r = ranks.json(file("reference.json"), st.key);
    if (r && r->at("cycles").size() > st.ref_cycles.size()) {
      st.ref_cycles = cycles_from(r->at("cycles"));
      st.ref_rows.clear();
      for (const auto& c : r->at("rows")) st.ref_rows.push_back(rows_from(c));
      st.ref_partition = partitions_from(*r, st.ref_cycles.size(), case_.aero.cfd.fpm.body);
      st.ref_sim.reset();
      st.ref_fpm.reset();
      st.ref_on_file = true;
    }
  }
  while (int(st.ref_cycles.size()) < k) {
    if (!st.ref_sim) {
      st.ref_sim = std::make_unique<Simulation>(st.base_case, st.base_kin, BodyMotion{}, st.plan, ranks.options());
      std::optional<SimulationState> end;  // the cached reference's state after its last wingbeat
      const long end_step = st.hover_state.step + long(st.ref_cycles.size()) * n;
      if (st.ref_on_file && !st.ref_cycles.empty() && ranks.exists(file("reference.h5"))) {
        const CheckpointReader ck(file("reference.h5"));
        end = ranks.read(ck, plan_grid(st.plan));
        if (end->step != end_step) end.reset();
      }
      if (!end && !st.ref_cycles.empty()) {
        // A state that does not belong to the kept cycles (killed between the two writes): the reference is made
        // again from the hover (the same steps, the same numbers).
        say(fmt::format("  the kept continued hover ({}) does not end at its {} wingbeats; it is made again\n",
                        file("reference.h5"), st.ref_cycles.size()));
        st.ref_cycles.clear();
        st.ref_rows.clear();
        st.ref_partition.clear();
      }
      st.ref_on_file = false;
      st.ref_sim->restore(end ? *end : st.hover_state);
      if (s.fpm.enabled) st.ref_fpm = std::make_unique<fpm::FpmObserver>(*st.ref_sim, s.fpm, std::string());
    }
    std::vector<CfdLoadRow> rr;
    const double ref_from = st.ref_sim->time();
    for (int i = 0; i < n; ++i) {
      const StepReport r = st.ref_sim->advance();
      rr.push_back(r.row);
      if (st.ref_fpm) st.ref_fpm->on_step(*st.ref_sim, r);
    }
    st.ref_partition.resize(st.ref_cycles.size());
    if (st.ref_fpm)
      st.ref_partition.push_back(partition_means(*st.ref_fpm, ref_from, st.ref_sim->time(), st.plan.dt));
    else
      st.ref_partition.emplace_back();
    CycleRecord cr;
    cr.cycle = int(st.ref_cycles.size()) + 1;
    cr.mean = mean_of(rr);
    if (!st.ref_cycles.empty()) cr.change = cycle_change(cr.mean, st.ref_cycles.back().mean, st.hover_settings);
    st.ref_cycles.push_back(cr);
    st.ref_rows.push_back(rr);
    say(fmt::format("  reference wingbeat {:>2}: mean F = ({:+.4e}, {:+.4e}, {:+.4e}) N\n", cr.cycle,
                    cr.mean.force.x(), cr.mean.force.y(), cr.mean.force.z()));
    if (!cache_.empty()) {
      write_state(file("reference.h5"), *st.ref_sim, {}, {{"key", st.key}});
      ranks.on_lead([&] {
        nlohmann::json rows = nlohmann::json::array();
        for (const auto& r : st.ref_rows) rows.push_back(rows_json(r));
        write_file_atomic(file("reference.json"),
                          nlohmann::json{{"key", st.key}, {"cycles", cycles_json(st.ref_cycles)}, {"rows", rows},
                                         {"partition", partitions_json(st.ref_partition)}}.dump(1) + "\n");
      });
    }
  }
}


PitchOscillationResult CfdModel::pitch_oscillation(const Insect& insect, const Kinematics& kin,
                                                   const PitchOscillationSpec& spec) const {
  if (!(spec.amplitude > 0) || spec.period_wingbeats < 3 || spec.periods < 1 || spec.transient() < 0)
    throw std::invalid_argument("CfdModel::pitch_oscillation: amplitude > 0, period >= 3 wingbeats, periods >= 1");
  // Checked before anything runs: other kinematics would first make a perturbed run of their own.
  if (st_ && fingerprint(insect, kin) != st_->base_print)
    throw SolveError("cfd model: a pitch oscillation runs about the base hover's kinematics only");
  run(insect, kin, BodyMotion{}, {});  // the kept hover (made, or read from the cache)
  State& st = *st_;
  auto file = [&](const std::string& name) { return cache_ + "/" + name; };
  auto say = [&](const std::string& line) {
    if (log_ && ranks_->rank() == 0) *log_ << line << std::flush;
  };
  const int n = st.plan.steps_per_cycle;
  const double T = st.plan.period;
  const int needed = spec.wingbeats();
  // The run's wingbeats do not depend on how many are fitted: one key per amplitude and period, extended on demand.
  const std::string key = fnv1a64_hex(st.key + "|pitch-oscillation, body frame|" +
                                      fmt::format("{:.17g} {}", spec.amplitude, spec.period_wingbeats));
  const std::string json_file = file("pitch_" + key + ".json"), h5_file = file("pitch_" + key + ".h5");
  PitchOscillationResult r;
  r.spec = spec;
  r.omega = 2 * std::numbers::pi / (spec.period_wingbeats * T);
  const std::string label = fmt::format("pitch oscillation of {:.3g} deg, period {} wingbeats",
                                        spec.amplitude * 180 / std::numbers::pi, spec.period_wingbeats);
  const Ranks ranks{ranks_};
  std::optional<FileLock> lock;
  if (!cache_.empty()) ranks.claim(lock, file("pitch_" + key + ".lock"), "the " + label, say);
  double earlier_seconds = 0;
  // The run's file is kept when it ends (a later study may extend it): its state after the last wingbeat and the
  // wingbeats so far, read back as a partial run's.
  const PartialRun kept_run{json_file, h5_file};
  std::optional<SimulationState> kept;
  if (const auto j = cache_.empty() ? std::nullopt : ranks.json(json_file, key)) {
    for (const auto& w : j->at("wingbeats")) {
      OscillationWingbeat o;
      o.theta = w.at("theta_rad").get<double>();
      o.rate = w.at("q_rad_s").get<double>();
      for (int i = 0; i < 3; ++i) {
        o.difference.force[i] = w.at("dF_N").at(std::size_t(i)).get<double>();
        o.difference.moment[i] = w.at("dM_N_m").at(std::size_t(i)).get<double>();
      }
      if (w.contains("dW_steps"))  // [dFx dFy dFz dMx dMy dMz] per step
        for (const auto& d : w.at("dW_steps"))
          o.steps.push_back(Wrench{Vec3(d.at(0).get<double>(), d.at(1).get<double>(), d.at(2).get<double>()),
                                   Vec3(d.at(3).get<double>(), d.at(4).get<double>(), d.at(5).get<double>())});
      r.wingbeats.push_back(o);
    }
    earlier_seconds = j->at("wall_s").get<double>();
    if (int(r.wingbeats.size()) < needed) {
      const std::string restart = "the " + label + " starts again from the hover";
      if (auto part = kept_run.read(ranks, key, plan_grid(st.plan), say, restart.c_str())) {
        kept = std::move(part->first);
      } else {
        if (!ranks.exists(h5_file)) say(fmt::format("  warning: {} has no state beside it; {}\n", json_file, restart));
        r.wingbeats.clear();
        earlier_seconds = 0;
      }
    }
  }
  if (int(r.wingbeats.size()) >= needed) {
    r.wingbeats.resize(std::size_t(needed));
    r.reused = true;
    r.wall_seconds = earlier_seconds;
    say(fmt::format("cfd model: {} reused from {}\n", label, json_file));
  } else {
    Case c = case_;
    c.insect = insect;
    // The grid turns with the body, which keeps its cells: a frame at rate (0, q(t), 0) about O, whose Coriolis and
    // Euler accelerations the solver carries, with the still air's far field -Omega(t) x r on the faces.
    const double start = st.hover_state.time;
    SimulationOptions options = ranks.options();
    options.frame_rotation.rate = [spec, T, start](double t) {
      return Vec3(0, pitch_oscillation_angle(spec, T, t - start).rate, 0);
    };
    options.frame_rotation.rate_rate = [spec, T, start](double t) {
      return Vec3(0, pitch_oscillation_angle(spec, T, t - start).rate_rate, 0);
    };
    Simulation sim(c, kin, BodyMotion{}, st.plan, options);
    // From the hover, whose far field is at rest: the body starts turning at q(0) impulsively.
    if (kept) {
      sim.restore(*kept);
    } else {
      sim.restore(st.hover_state, BodyMotion{});
    }
    say(fmt::format("cfd model: {} (q up to {:.4g} rad/s) from {}, {} wingbeats ({} left out, then {} period{} "
                    "fitted)\n",
                    label, spec.amplitude * r.omega,
                    kept ? fmt::format("its wingbeat {}", r.wingbeats.size()) : std::string("the kept hover state"),
                    needed, spec.transient(), spec.periods, spec.periods == 1 ? "" : "s"));
    const auto t0 = clock_type::now();
    for (int k = int(r.wingbeats.size()) + 1; k <= needed; ++k) {
      std::vector<Wrench> loads;
      std::vector<double> times;
      try {
        for (int i = 0; i < n; ++i) {
          const StepReport rep = sim.advance();
          loads.push_back(rep.row.total());  // the grid's axes are the body's
          times.push_back(rep.time);
        }
      } catch (const StepFailure& e) {
        throw SolveError(fmt::format("cfd model: the {} diverged in its wingbeat {} (step {}): {}", label, k, e.step(),
                                     e.why()));
      }
      continue_reference(k);
      const auto& ref = st.ref_rows[std::size_t(k - 1)];
      OscillationWingbeat o;
      for (int i = 0; i < n; ++i) {
        const PitchAngle a = pitch_oscillation_angle(spec, T, times[std::size_t(i)] - start);
        o.theta += a.theta / n;
        o.rate += a.rate / n;
        o.steps.push_back(loads[std::size_t(i)] + (-1.0) * ref[std::size_t(i)].total());
        o.difference += (1.0 / n) * o.steps.back();
      }
      r.wingbeats.push_back(o);
      say(fmt::format("  wingbeat {:>2}: theta {:+.3f} deg, q {:+.4g} rad/s; difference from the hover dF = ({:+.4e}, "
                      "{:+.4e}, {:+.4e}) N, dM = ({:+.4e}, {:+.4e}, {:+.4e}) N m\n",
                      k, o.theta * 180 / std::numbers::pi, o.rate, o.difference.force.x(), o.difference.force.y(),
                      o.difference.force.z(), o.difference.moment.x(), o.difference.moment.y(),
                      o.difference.moment.z()));
      r.wall_seconds = earlier_seconds + std::chrono::duration<double>(clock_type::now() - t0).count();
      if (!cache_.empty()) {
        nlohmann::json wj = nlohmann::json::array();
        for (const auto& w : r.wingbeats) {
          nlohmann::json steps = nlohmann::json::array();
          for (const Wrench& d : w.steps)
            steps.push_back({d.force.x(), d.force.y(), d.force.z(), d.moment.x(), d.moment.y(), d.moment.z()});
          wj.push_back({{"theta_rad", w.theta},
                        {"q_rad_s", w.rate},
                        {"dF_N", {w.difference.force.x(), w.difference.force.y(), w.difference.force.z()}},
                        {"dM_N_m", {w.difference.moment.x(), w.difference.moment.y(), w.difference.moment.z()}},
                        {"dW_steps", steps}});
        }
        kept_run.keep(ranks, key, sim,
                      {{"label", label}, {"amplitude_rad", spec.amplitude}, {"period_wingbeats", spec.period_wingbeats},
                       {"wingbeats", wj}, {"wall_s", r.wall_seconds}});
      }
    }
    say(fmt::format("cfd model: {} done: {} wingbeats in {:.1f} s\n", label, needed, r.wall_seconds));
  }
  fit_pitch_oscillation(r);
  if (r.phase.empty() && !cache_.empty()) r.phase_note += " (" + json_file + ")";
  return r;
}

}  // namespace flapstab::ns
