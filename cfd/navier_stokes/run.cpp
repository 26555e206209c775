// The CFD run driver (run.hpp): plan, checks, estimate, time stepping, loads, outputs, checkpoints, restart.
#include "cfd/navier_stokes/run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <ostream>
#include <regex>
#include <sstream>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <omp.h>

#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/io_hdf5.hpp"
#include "cfd/navier_stokes/io_vtk.hpp"
#include "cfd/navier_stokes/solver.hpp"
#include "core/atomic_write.hpp"
#include "core/configuration.hpp"
#include "core/errors.hpp"
#include "cfd/navier_stokes/immersed.hpp"

namespace flapstab::ns {

namespace fs = std::filesystem;

namespace {

const char* const part_names[3] = {"body", "right", "left"};

// The whole insect's rotation about O at time t (body rates Omega, turning the insect in the grid).
RigidTransform body_rotation(const BodyMotion& m, double t) {
  RigidTransform b;
  const double w = m.rate.norm();
  if (w > 0) b.rotation = Eigen::AngleAxisd(w * t, m.rate / w).toRotationMatrix();
  return b;
}

// Part i in grid axes: the body's rotation composed with the part's motion relative to the body.
struct GridPart {
  RigidTransform pose;
  RigidVelocity velocity;          // all motion (grid frame)
  RigidVelocity relative;          // motion relative to the body, expressed in grid axes
};

GridPart grid_part(const PartPose& r, const BodyMotion& m, double t) {
  const RigidTransform b = body_rotation(m, t);
  GridPart g;
  g.pose = b * r.pose;
  g.relative.centre = b.apply(r.motion.centre);
  g.relative.velocity = b.rotation * r.motion.velocity;
  g.relative.omega = b.rotation * r.motion.omega;
  g.velocity = g.relative;
  g.velocity.velocity += m.rate.cross(g.relative.centre);
  g.velocity.omega += m.rate;
  return g;
}

MeshResolution mesh_resolution(const CfdSettings& s) {
  MeshResolution r;
  r.body = s.body_divisions;
  r.wing_span = s.wing_span_stations;
  r.wing_chord = s.wing_chord_divisions;
  return r;
}

std::string grid_summary(const Grid& g) {
  std::string s = fmt::format("{}x{}x{}", g.axis[0].n, g.axis[1].n, g.axis[2].n);
  for (const auto& a : g.axis) s += fmt::format(" [{:.17g},{:.17g},{:.17g}]", a.lo, a.hi, a.min_width());
  return s;
}

std::string hex64(std::uint64_t h) { return fmt::format("{:016x}", h); }

// Cell-centre velocity, vorticity and Q criterion (central differences on the non-uniform centres, one-sided at
// the domain faces).
struct CentreFields {
  std::vector<double> u[3], w[3], q;
};

CentreFields centre_fields(const Grid& g, const VectorField& u) {
  const Shape s = g.shape();
  const std::size_t n = s.cells();
  CentreFields f;
  for (int d = 0; d < 3; ++d) {
    f.u[d].assign(n, 0.0);
    f.w[d].assign(n, 0.0);
  }
  f.q.assign(n, 0.0);
  auto flat = [&](int i, int j, int k) { return (std::size_t(k - 1) * s.ny + (j - 1)) * s.nx + (i - 1); };
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const int I[3] = {i, j, k};
        for (int d = 0; d < 3; ++d) {
          int J[3] = {i, j, k};
          ++J[d];
          f.u[d][flat(i, j, k)] = 0.5 * (u[d](I[0], I[1], I[2]) + u[d](J[0], J[1], J[2]));
        }
      }
  const int nn[3] = {s.nx, s.ny, s.nz};
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        double G[3][3];  // G[a][b] = d u_a / d x_b
        for (int b = 0; b < 3; ++b) {
          int lo[3] = {i, j, k}, hi[3] = {i, j, k};
          lo[b] = std::max(1, lo[b] - 1);
          hi[b] = std::min(nn[b], hi[b] + 1);
          const double dx = g.axis[b].xc[hi[b]] - g.axis[b].xc[lo[b]];
          for (int a = 0; a < 3; ++a)
            G[a][b] = dx > 0 ? (f.u[a][flat(hi[0], hi[1], hi[2])] - f.u[a][flat(lo[0], lo[1], lo[2])]) / dx : 0.0;
        }
        const std::size_t c = flat(i, j, k);
        f.w[0][c] = G[2][1] - G[1][2];
        f.w[1][c] = G[0][2] - G[2][0];
        f.w[2][c] = G[1][0] - G[0][1];
        double ss = 0, oo = 0;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const double sym = 0.5 * (G[a][b] + G[b][a]), anti = 0.5 * (G[a][b] - G[b][a]);
            ss += sym * sym;
            oo += anti * anti;
          }
        f.q[c] = 0.5 * (oo - ss);
      }
  return f;
}

RectilinearAxes rectilinear(const Grid& g) {
  RectilinearAxes a;
  std::vector<double>* out[3] = {&a.x, &a.y, &a.z};
  for (int d = 0; d < 3; ++d) out[d]->assign(g.axis[d].xf.begin() + 1, g.axis[d].xf.begin() + g.axis[d].n + 2);
  return a;
}

// Step of a checkpoint file name, or -1.
long checkpoint_step(const std::string& file) {
  static const std::regex re(R"(checkpoint_(\d+)\.h5)");
  std::smatch m;
  return std::regex_match(file, m, re) ? std::stol(m[1].str()) : -1;
}

std::vector<std::pair<long, std::string>> checkpoints_in(const std::string& dir) {
  std::vector<std::pair<long, std::string>> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    const long s = checkpoint_step(e.path().filename().string());
    if (s >= 0 && e.is_regular_file()) out.emplace_back(s, e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string fmt_seconds(double s) {
  if (!std::isfinite(s)) return "?";
  if (s < 120) return fmt::format("{:.1f} s", s);
  if (s < 7200) return fmt::format("{:.1f} min", s / 60);
  return fmt::format("{:.2f} h", s / 3600);
}

// The insect in the immersed boundary: three parts moved by the kinematics and the body motion; loads by the
// method [aero.cfd] loads names.
class Bodies {
 public:
  Bodies(const Grid& grid, double rho, const std::vector<TriangleMesh>& reference, const Configuration& config,
         const BodyMotion& motion, bool exchange)
      : ib_(grid, ImmersedOptions{.density = rho}), exchange_(exchange) {
    for (int i = 0; i < 3; ++i) {
      PartMotion m = [&config, motion, i](double t) {
        const GridPart g = grid_part(insect_part_poses(config, t)[std::size_t(i)], motion, t);
        return PartState{g.pose, g.velocity};
      };
      ib_.add_part(reference[std::size_t(i)], std::move(m));
    }
  }
  void attach(Solver& s) { ib_.attach(s); }
  std::size_t bytes() const { return ib_.bytes(); }
  std::vector<PartLoads> loads(const Solver& s) const {
    return exchange_ ? ib_.exchange_loads(s, Vec3::Zero()) : ib_.loads(s, Vec3::Zero());
  }
  TriangleMesh surface(int part, double t) const { return ib_.surface(part, t); }
  SurfacePressure pressure(const Solver& s, int part) const { return ib_.surface_pressure(s, part); }

 private:
  ImmersedBoundary ib_;
  bool exchange_;
};

}  // namespace

// ---- plan ------------------------------------------------------------------------------------------------------

CfdPlan plan_cfd(const Case& c, const Kinematics& kin, const BodyMotion& motion, int cycles_override) {
  const CfdSettings& s = c.aero.cfd;
  const std::string& file = c.path;
  CfdPlan p;
  p.cycles = cycles_override > 0 ? cycles_override : s.cycles;
  p.period = kin.period();
  const double R = c.insect.wing.length, cbar = c.insect.wing.mean_chord;
  p.rho = c.fluid.density;
  p.u_ref = 2 * kin.stroke_amplitude() * kin.frequency_hz * R;
  p.l_ref = cbar;
  if (s.reynolds > 0) {
    if (!(p.u_ref > 0))
      throw InputError(file, "aero.cfd.reynolds", "the wings do not move (U_ref = 2 Phi f R = 0)",
                       "a case with a non-zero stroke amplitude, or [fluid] viscosity instead");
    p.reynolds = s.reynolds;
    p.nu = p.u_ref * p.l_ref / s.reynolds;
  } else {
    p.nu = c.fluid.kinematic_viscosity;
    p.reynolds = p.u_ref * p.l_ref / p.nu;
  }
  // Swept volume: every vertex of every part over the run (one wingbeat suffices without body rotation).
  const Configuration config(c.insect, kin);
  const InsectSurfaces surfaces(config, mesh_resolution(s));
  const auto& ref = surfaces.reference();
  const bool rotating = motion.rate.norm() > 0;
  const int samples = rotating ? std::min(64 * p.cycles, 1024) : 64;
  const double span = rotating ? p.cycles * p.period : p.period;
  BoundingBox box;
  for (int k = 0; k <= samples; ++k) {
    const double t = span * k / samples;
    const auto rel = insect_part_poses(config, t);
    for (int i = 0; i < 3; ++i) {
      const GridPart g = grid_part(rel[std::size_t(i)], motion, t);
      for (const Vec3& v : ref[std::size_t(i)].vertices) {
        const Vec3 x = g.pose.apply(v);
        box.add(x);
        if (i > 0) p.tip_speed_max = std::max(p.tip_speed_max, g.relative.at(x).norm());
      }
    }
  }
  p.swept_lo = box.lo;
  p.swept_hi = box.hi;
  p.h = s.cells_per_wing_length > 0 ? R / s.cells_per_wing_length : cbar / s.cells_per_chord;
  const std::string res_key = s.cells_per_wing_length > 0 ? "aero.cfd.cells_per_wing_length" : "aero.cfd.cells_per_chord";
  p.fine_lo = box.lo - Vec3::Constant(s.fine_margin_R * R);
  p.fine_hi = box.hi + Vec3::Constant(s.fine_margin_R * R);
  // Faces: x- downstream (behind), x+ upstream (ahead), y +-lateral, z- above, z+ below.
  const double lo_margin[3] = {s.downstream_R, s.lateral_R, s.above_R};
  const double hi_margin[3] = {s.upstream_R, s.lateral_R, s.below_R};
  const char* lo_key[3] = {"aero.cfd.downstream_R", "aero.cfd.lateral_R", "aero.cfd.above_R"};
  const char* hi_key[3] = {"aero.cfd.upstream_R", "aero.cfd.lateral_R", "aero.cfd.below_R"};
  for (int d = 0; d < 3; ++d) {
    p.domain_lo[d] = p.fine_lo[d] - lo_margin[d] * R;
    p.domain_hi[d] = p.fine_hi[d] + hi_margin[d] * R;
    StretchedAxis a;
    a.lo = p.domain_lo[d];
    a.hi = p.domain_hi[d];
    a.box_lo = p.fine_lo[d];
    a.box_hi = p.fine_hi[d];
    a.h = p.h;
    a.max_ratio = s.stretch_ratio;
    a.multiple_of = 8;
    p.axes.push_back(a);
  }
  // The immersed boundary's forcing band and probes reach about 4 fine cells beyond a surface: every part must
  // stay that far from the box faces over the whole run.
  const double clearance = 4 * p.h;
  for (int d = 0; d < 3; ++d)
    for (int side = 0; side < 2; ++side) {
      const double gap = side == 0 ? p.swept_lo[d] - p.domain_lo[d] : p.domain_hi[d] - p.swept_hi[d];
      if (gap < clearance)
        throw InputError(file, (side == 0 ? lo_key : hi_key)[d],
                         fmt::format("a part comes within {:.3g} m of the domain's {}{} face (the run needs {:.3g} m, "
                                     "4 fine cells): the insect leaves the domain",
                                     gap, "xyz"[d], side == 0 ? '-' : '+', clearance),
                         "a larger margin (this key or aero.cfd.fine_margin_R)");
    }
  // The fine box's actual spacing (the generator rounds the cell count up).
  double hmax = 0;
  for (int d = 0; d < 3; ++d) {
    const Axis a = Axis::stretched(p.axes[std::size_t(d)], false);
    for (int i = 1; i <= a.n; ++i)
      if (a.xc[i] > p.fine_lo[d] && a.xc[i] < p.fine_hi[d]) hmax = std::max(hmax, a.dc[i]);
  }
  p.h_actual = hmax > 0 ? hmax : p.h;
  p.chord_cells = cbar / p.h_actual;
  if (p.chord_cells < 4)
    throw InputError(file, res_key,
                     fmt::format("the mean chord ({:.4g} m) spans only {:.2f} fine cells (h = {:.4g} m)", cbar,
                                 p.chord_cells, p.h_actual),
                     "at least 4 cells per mean chord (8 or more recommended)");
  if (p.chord_cells < 8)
    p.warnings.push_back(fmt::format("the mean chord spans only {:.2f} fine cells: loads will be rough "
                                     "(8 or more recommended; key {})", p.chord_cells, res_key));
  if (s.stretch_ratio > 1.08)
    p.warnings.push_back(fmt::format("stretch_ratio = {} above 1.08: the multigrid preconditioner converges more "
                                     "slowly on strongly stretched cells", s.stretch_ratio));
  p.steps_per_cycle = s.steps_per_cycle;
  if (p.steps_per_cycle > 0) {
    p.dt = p.period / p.steps_per_cycle;
    const double speed = p.tip_speed_max + motion.velocity.norm();
    const double cfl = p.dt * speed / p.h_actual;
    if (cfl > 1.0)
      p.warnings.push_back(fmt::format("steps_per_cycle = {}: the wingtip moves {:.2f} fine cells per step (CFL "
                                       "estimate {:.2f} > 1); the run may diverge", p.steps_per_cycle, cfl, cfl));
  }
  return p;
}

// ---- loads rows and forces.csv ---------------------------------------------------------------------------------

Wrench CfdLoadRow::total() const {
  Wrench w;
  for (const auto& q : part) {
    w.force += q.pressure_force + q.viscous_force;
    w.moment += q.pressure_moment + q.viscous_moment;
  }
  return w;
}

std::string forces_csv_header() {
  std::string h =
      "# flapstab cfd: loads of the fluid on each part at every time step\n"
      "# axes: hover stability axes S (x forward, y right, z down), body-fixed; origin O = wingbeat-mean centre of "
      "mass; moments about O\n"
      "# units: time s, force N, moment N m, power W; phase = t / T modulo 1\n"
      "# parts: body, right (wing), left (wing); p = pressure part, v = viscous part; P = the part's rate of work on "
      "the air; wing_power_W = the wings' work on the air through their motion relative to the body\n";
  std::string cols = "time_s,step,phase";
  for (const char* part : part_names) {
    for (const char* kind : {"p", "v"})
      for (const char* a : {"x", "y", "z"}) cols += fmt::format(",{}_F{}_{}_N", part, a, kind);
    for (const char* kind : {"p", "v"})
      for (const char* a : {"x", "y", "z"}) cols += fmt::format(",{}_M{}_{}_N_m", part, a, kind);
    cols += fmt::format(",{}_P_W", part);
  }
  cols += ",Fx_N,Fy_N,Fz_N,Mx_N_m,My_N_m,Mz_N_m,wing_power_W";
  return h + cols + "\n";
}

std::string forces_csv_row(const CfdLoadRow& r) {
  std::string s = fmt::format("{:.17g},{},{:.17g}", r.time, r.step, r.phase);
  auto v3 = [&](const Vec3& v) { s += fmt::format(",{:.17g},{:.17g},{:.17g}", v.x(), v.y(), v.z()); };
  for (const auto& q : r.part) {
    v3(q.pressure_force);
    v3(q.viscous_force);
    v3(q.pressure_moment);
    v3(q.viscous_moment);
    s += fmt::format(",{:.17g}", q.power);
  }
  const Wrench w = r.total();
  v3(w.force);
  v3(w.moment);
  s += fmt::format(",{:.17g}\n", r.wing_power);
  return s;
}

CfdLoadRow parse_forces_csv_row(const std::string& line) {
  std::vector<double> v;
  std::size_t pos = 0;
  while (pos <= line.size()) {
    std::size_t next = line.find(',', pos);
    if (next == std::string::npos) next = line.size();
    const std::string cell = line.substr(pos, next - pos);
    std::size_t used = 0;
    const double x = std::stod(cell, &used);
    if (used == 0) throw std::invalid_argument("forces.csv: not a number: " + cell);
    v.push_back(x);
    pos = next + 1;
  }
  if (v.size() != 3 + 3 * 13 + 7) throw std::invalid_argument("forces.csv: a row with " + std::to_string(v.size()) + " columns");
  CfdLoadRow r;
  r.time = v[0];
  r.step = long(v[1]);
  r.phase = v[2];
  std::size_t k = 3;
  auto v3 = [&] {
    const Vec3 a(v[k], v[k + 1], v[k + 2]);
    k += 3;
    return a;
  };
  for (auto& q : r.part) {
    q.pressure_force = v3();
    q.viscous_force = v3();
    q.pressure_moment = v3();
    q.viscous_moment = v3();
    q.power = v[k++];
  }
  r.wing_power = v.back();
  return r;
}

std::string case_hash(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint64_t h = 1469598103934665603ull;
  char ch;
  while (in.get(ch)) {
    h ^= static_cast<unsigned char>(ch);
    h *= 1099511628211ull;
  }
  return hex64(h);
}

// ---- the run ---------------------------------------------------------------------------------------------------

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
  if (s.threads > 0) omp_set_num_threads(s.threads);

  // Restart: the newest checkpoint that opens and belongs to this case.
  const std::string ckdir = o.directory + "/checkpoints";
  const std::string hash = c.path.empty() ? std::string("none") : case_hash(c.path);
  std::optional<CheckpointReader> ck;
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
  }


  // Grid, boundaries, solver.
  Grid grid(Axis::stretched(plan.axes[0], false), Axis::stretched(plan.axes[1], false),
            Axis::stretched(plan.axes[2], false));
  if (ck && (!ck->header().text.count("grid") || ck->header().text.at("grid") != grid_summary(grid)))
    throw InputError(c.path, "--restart", "the checkpoint's grid differs from this run's (cycles or body motion changed?)",
                     "the settings of the interrupted run");
  Boundaries bc;
  const Vec3 stream = -motion.velocity;
  for (int f = 0; f < 6; ++f) {
    bc.face[std::size_t(f)].type = BC::velocity;
    if (stream.norm() > 0) bc.face[std::size_t(f)].velocity = [stream](double) { return stream; };
  }
  bc.face[std::size_t(face(2, 1))] = FaceCondition{BC::outflow, {}};
  SolverOptions so;
  so.nu = plan.nu;
  so.cfl = s.cfl;
  so.dt = plan.dt;
  const double speed = plan.tip_speed_max + motion.velocity.norm();
  if (speed > 0) so.dt_max = s.cfl * plan.h_actual / speed;
  else so.dt_max = plan.period / 100;
  Solver solver(grid, bc, so);
  if (o.initial_velocity) solver.initialise([&](double x, double y, double z) { return o.initial_velocity(x, y, z); });
  else solver.initialise([stream](double, double, double) { return stream; });

  const Configuration config(c.insect, kin);
  const InsectSurfaces surfaces(config, mesh_resolution(s));
  std::optional<Bodies> bodies;
  if (o.bodies) bodies.emplace(grid, plan.rho, surfaces.reference(), config, motion, s.loads == "exchange");

  long step = 0;
  if (ck) {
    const Shape sh = grid.shape();
    VectorField u(sh), phi(sh);
    Field p(sh);
    for (int d = 0; d < 3; ++d) {
      ck->read(fmt::format("u{}", d), std::span<double>(u[d].data(), sh.size()));
      ck->read(fmt::format("phi{}", d), std::span<double>(phi[d].data(), sh.size()));
    }
    ck->read("p", std::span<double>(p.data(), sh.size()));
    const bool guess = ck->header().values.at("guess") != 0;
    solver.restore(ck->header().time, u, p, phi, guess);
    if (bodies) {
      bodies->attach(solver);
      solver.restore(ck->header().time, u, p, phi, guess);  // now with the immersed boundary's after_projection
    }
    step = ck->header().step;
    res.start_step = step;
  } else if (bodies) {
    bodies->attach(solver);
  }

  res.cells = grid.cells();
  res.bytes = solver.bytes() + (bodies ? bodies->bytes() : 0);
  const double t_end = plan.cycles * plan.period;
  const long total_steps = plan.steps_per_cycle > 0 ? long(plan.cycles) * plan.steps_per_cycle : 0;
  const auto in_run = [&](long k, double t) {
    return plan.steps_per_cycle > 0 ? k < total_steps : t < t_end * (1 - 1e-12);
  };
  const double t0 = solver.time();
  const double dt_guess = plan.dt > 0 ? plan.dt : std::min(so.dt_max, solver.stable_dt());
  const double steps_left_est = plan.steps_per_cycle > 0 ? double(total_steps - step) : (t_end - t0) / dt_guess;
  if (log) {
    *log << fmt::format("flapstab cfd: {} ({}), Re = {:.4g} (U_ref = 2 Phi f R = {:.4g} m/s, L_ref = mean chord = "
                        "{:.4g} m, nu = {:.4g} m^2/s)\n",
                        c.insect.name, c.path, plan.reynolds, plan.u_ref, plan.l_ref, plan.nu);
    *log << fmt::format("  grid {} x {} x {} = {} cells, fine spacing {:.4g} m ({:.1f} cells per mean chord), domain "
                        "[{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] x [{:.4g}, {:.4g}] m\n",
                        grid.axis[0].n, grid.axis[1].n, grid.axis[2].n, res.cells, plan.h_actual, plan.chord_cells,
                        plan.domain_lo.x(), plan.domain_hi.x(), plan.domain_lo.y(), plan.domain_hi.y(),
                        plan.domain_lo.z(), plan.domain_hi.z());
    *log << fmt::format("  memory {:.1f} MiB ({:.0f} bytes per cell: solver {:.1f} MiB, immersed boundary {:.1f} MiB)\n",
                        res.bytes / 1048576.0, double(res.bytes) / res.cells, solver.bytes() / 1048576.0,
                        (bodies ? bodies->bytes() : 0) / 1048576.0);
    *log << fmt::format("  {} cycles of {:.4g} s, {}{} steps{}\n", plan.cycles, plan.period,
                        plan.steps_per_cycle > 0 ? "" : "about ", long(std::ceil(steps_left_est)),
                        plan.steps_per_cycle > 0 ? fmt::format(" (dt = T/{} = {:.4g} s)", plan.steps_per_cycle, plan.dt)
                                                 : fmt::format(" (adaptive dt, CFL {})", s.cfl));
    if (ck) *log << "  restarting from " << res.restarted_from << fmt::format(" (step {}, t = {:.6g} s)\n", step, t0);
    for (const auto& w : plan.warnings) *log << "  warning: " << w << "\n";
  }

  // Outputs (created lazily: bad input and dry runs write nothing).
  std::optional<FieldWriter> fields;
  std::optional<SurfaceWriter> surf_writer;
  std::vector<std::string> csv_rows;  // data rows of forces.csv
  std::vector<CfdLoadRow> earlier;    // rows of the interrupted run up to the checkpoint (restart)
  std::string last_checkpoint;
  long last_checkpoint_step = -1;
  if (write) {
    fs::create_directories(o.directory);
    if (ck) {  // keep the rows up to the checkpoint
      std::ifstream in(o.directory + "/forces.csv");
      std::string line;
      while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#' || line.rfind("time_s", 0) == 0) continue;
        const auto a = line.find(','), b = line.find(',', a + 1);
        if (a == std::string::npos || b == std::string::npos) continue;
        if (std::stol(line.substr(a + 1, b - a - 1)) <= step) {
          csv_rows.push_back(line + "\n");
          earlier.push_back(parse_forces_csv_row(line));
        }
      }
      last_checkpoint = res.restarted_from;
      last_checkpoint_step = step;
    }
  }
  auto flush_csv = [&] {
    if (!write) return;
    std::string text = forces_csv_header();
    for (const auto& r : csv_rows) text += r;
    write_file_atomic(o.directory + "/forces.csv", text);
  };
  auto checkpoint = [&](double dt_last) {
    if (!write) return;
    const Shape sh = grid.shape();
    CheckpointHeader h;
    h.time = solver.time();
    h.step = step;
    h.values = {{"dt", dt_last}, {"guess", solver.has_guess() ? 1.0 : 0.0}, {"reynolds", plan.reynolds},
                {"nu", plan.nu}, {"density", plan.rho}, {"period", plan.period}};
    h.text = {{"case_hash", hash}, {"case", c.path}, {"grid", grid_summary(grid)}};
    std::vector<CheckpointArray> arrays;
    const std::vector<std::size_t> shape = {std::size_t(sh.nz + 2), std::size_t(sh.ny + 2), std::size_t(sh.nx + 2)};
    for (int d = 0; d < 3; ++d)
      arrays.push_back({fmt::format("u{}", d), std::span<const double>(solver.velocity()[d].data(), sh.size()), shape});
    arrays.push_back({"p", std::span<const double>(solver.pressure().data(), sh.size()), shape});
    for (int d = 0; d < 3; ++d)
      arrays.push_back({fmt::format("phi{}", d),
                        std::span<const double>(solver.pressure_increments()[d].data(), sh.size()), shape});
    const std::string path = fmt::format("{}/checkpoint_{:09d}.h5", ckdir, step);
    fs::create_directories(ckdir);
    write_checkpoint(path, h, arrays);
    flush_csv();
    last_checkpoint = path;
    last_checkpoint_step = step;
    auto list = checkpoints_in(ckdir);  // keep the last two
    for (std::size_t i = 0; i + 2 < list.size(); ++i) fs::remove(list[i].second);
  };
  auto write_fields = [&] {
    if (!write) return;
    if (!fields)
      fields.emplace(o.directory + "/fields", "fields", rectilinear(grid),
                     s.field_precision == "float32" ? FieldPrecision::float32 : FieldPrecision::float64);
    const CentreFields cf = centre_fields(grid, solver.velocity());
    const Shape sh = grid.shape();
    std::vector<double> pa(sh.cells());
    std::size_t n = 0;
    for (int k = 1; k <= sh.nz; ++k)
      for (int j = 1; j <= sh.ny; ++j)
        for (int i = 1; i <= sh.nx; ++i) pa[n++] = plan.rho * solver.pressure()(i, j, k);
    auto arr = [](const std::vector<double>& v) { return CellArray{v.data()}; };
    fields->write(solver.time(), step,
                  {CellField{"velocity", "m/s", {arr(cf.u[0]), arr(cf.u[1]), arr(cf.u[2])}},
                   CellField{"pressure", "Pa", {arr(pa)}},
                   CellField{"vorticity", "1/s", {arr(cf.w[0]), arr(cf.w[1]), arr(cf.w[2])}},
                   CellField{"q_criterion", "1/s^2", {arr(cf.q)}}});
  };
  auto write_surfaces = [&] {
    if (!write || !bodies) return;
    if (!surf_writer) surf_writer.emplace(o.directory + "/surfaces", "surfaces");
    std::vector<TriangleMesh> meshes;
    std::vector<SurfacePart> parts;
    for (int i = 0; i < 3; ++i) meshes.push_back(bodies->surface(i, solver.time()));
    for (int i = 0; i < 3; ++i) {
      const SurfacePressure sp = bodies->pressure(solver, i);
      SurfacePart part{&meshes[std::size_t(i)], {}};
      part.data.cell_data.push_back({"pressure", "Pa", 1, sp.front});
      if (!sp.back.empty()) part.data.cell_data.push_back({"pressure_back", "Pa", 1, sp.back});
      parts.push_back(std::move(part));
    }
    surf_writer->write(solver.time(), step, parts);
  };
  auto crossed = [&](int per_cycle, double ta, double tb) {
    if (per_cycle <= 0) return false;
    const double n = per_cycle / plan.period;
    return std::floor(tb * n + 1e-6) > std::floor(ta * n + 1e-6);
  };

  auto diverged = [&](const std::string& why, long at_step, double t) -> SolveError {
    try {
      flush_csv();
    } catch (...) {
    }
    return SolveError(fmt::format(
        "the CFD run diverged at step {} (t = {:.6g} s, t/T = {:.4f}): {}; {}", at_step, t, t / plan.period, why,
        last_checkpoint.empty() ? std::string("no checkpoint was written")
                                : fmt::format("the last checkpoint, {} (step {}), is kept; lower the time step "
                                              "(aero.cfd.steps_per_cycle or aero.cfd.cfl) and restart",
                                              last_checkpoint, last_checkpoint_step)));
  };

  if (write && !ck) {  // the initial state: fields, surfaces, and a checkpoint to fall back on
    if (s.fields_per_cycle > 0) write_fields();
    if (s.surfaces_per_cycle > 0) write_surfaces();
    if (s.checkpoints_per_cycle > 0) checkpoint(0);
  }

  // Time stepping.
  const auto t_loop = clock::now();
  auto t_last_log = t_loop;
  clock::time_point t_after_warmup = t_loop;
  long warm_steps = 0;
  double dt = 0;
  auto finish_timings = [&] {
    res.steps = step;
    const auto t_done = clock::now();
    res.wall_seconds = std::chrono::duration<double>(t_done - t_start).count();
    if (warm_steps > 2)
      res.seconds_per_step = std::chrono::duration<double>(t_done - t_after_warmup).count() / double(warm_steps - 2);
    else
      res.seconds_per_step = res.seconds_per_step_estimate;
  };
  while (in_run(step, solver.time())) {
    const double ta = solver.time();
    const auto t_step0 = clock::now();
    try {
      dt = solver.step();
    } catch (const std::exception& e) {
      throw diverged(e.what(), step + 1, ta);
    }
    ++step;
    const double tb = solver.time();
    // Loads.
    CfdLoadRow row;
    row.time = tb;
    row.step = step;
    row.phase = tb / plan.period - std::floor(tb / plan.period + 1e-12);
    if (row.phase < 0) row.phase = 0;
    if (bodies) {
      const auto loads = bodies->loads(solver);
      const Mat3 Rt = body_rotation(motion, tb).rotation.transpose();
      const auto rel = insect_part_poses(config, tb);
      for (int i = 0; i < 3; ++i) {
        const PartLoads& L = loads[std::size_t(i)];
        auto& q = row.part[i];
        q.pressure_force = Rt * L.pressure_force;
        q.viscous_force = Rt * L.viscous_force;
        q.pressure_moment = Rt * L.pressure_moment;
        q.viscous_moment = Rt * L.viscous_moment;
        q.power = L.power;
        if (i > 0) {  // wing's work through its motion relative to the body: -(F . v_c + M_c . omega)
          const GridPart g = grid_part(rel[std::size_t(i)], motion, tb);
          const Vec3 F = L.force(), Mc = L.moment() - g.relative.centre.cross(F);
          row.wing_power += -(F.dot(g.relative.velocity) + Mc.dot(g.relative.omega));
        }
      }
    }
    // Divergence checks.
    bool finite = std::isfinite(solver.kinetic_energy()) && std::isfinite(row.wing_power);
    for (const auto& q : row.part)
      finite = finite && q.pressure_force.allFinite() && q.viscous_force.allFinite() &&
               q.pressure_moment.allFinite() && q.viscous_moment.allFinite() && std::isfinite(q.power);
    if (!finite) throw diverged("the solution or the loads are not finite", step, tb);
    const double cfl_now = solver.cfl(dt);
    if (!(cfl_now <= std::sqrt(3.0)))
      throw diverged(fmt::format("CFL {:.3g} above the RK3 limit 1.73 (the flow blew up)", cfl_now), step, tb);
    res.rows.push_back(row);
    csv_rows.push_back(forces_csv_row(row));

    // Estimate after two warm-up steps.
    if (++warm_steps == 2 || (!in_run(step, tb) && warm_steps < 2)) {
      t_after_warmup = clock::now();
      res.seconds_per_step_estimate = std::chrono::duration<double>(t_after_warmup - t_loop).count() / warm_steps;
      const double left = plan.steps_per_cycle > 0 ? double(total_steps - step) : (t_end - tb) / dt;
      if (log)
        *log << fmt::format("  estimate (timed on the first {} steps): {:.3g} s per step = {:.0f} ns per cell per step; "
                            "{} for the {:.0f} steps left\n",
                            warm_steps, res.seconds_per_step_estimate, 1e9 * res.seconds_per_step_estimate / res.cells,
                            fmt_seconds(res.seconds_per_step_estimate * left), std::max(0.0, left));
      if (o.dry_run) break;
    }
    // Outputs.
    if (crossed(s.fields_per_cycle, ta, tb)) write_fields();
    if (crossed(s.surfaces_per_cycle, ta, tb)) write_surfaces();
    if (crossed(s.checkpoints_per_cycle, ta, tb)) checkpoint(dt);
    // Progress.
    const auto now = clock::now();
    if (log && (std::chrono::duration<double>(now - t_last_log).count() >= o.progress_seconds || !in_run(step, tb) ||
                crossed(1, ta, tb))) {
      t_last_log = now;
      int iters = 0;
      for (const auto& st : solver.poisson_stats()) iters += st.cycles;
      const double per = std::chrono::duration<double>(now - t_loop).count() / std::max<long>(1, warm_steps);
      const double left = plan.steps_per_cycle > 0 ? double(total_steps - step) : std::max(0.0, (t_end - tb) / dt);
      *log << fmt::format("  step {:>7}  t/T {:8.4f}  cycle {:>3}  dt {:.3e} s  CFL {:.3f}  Poisson {:>2} it  ETA {}\n",
                          step, tb / plan.period, std::max(1, int(std::ceil(tb / plan.period - 1e-9))), dt, cfl_now,
                          iters, fmt_seconds(per * left));
    }
    (void)t_step0;
    if (o.stop_after_steps > 0 && step >= o.stop_after_steps && in_run(step, tb)) {
      finish_timings();
      flush_csv();
      return res;
    }
  }
  finish_timings();
  if (o.dry_run) return res;

  // Rows of the last wingbeat, with the one at its start when the run has it (the previous wingbeat's last step).
  const double last_start = (plan.cycles - 1) * plan.period;
  for (const auto* rows : {&earlier, &res.rows})
    for (const auto& r : *rows)
      if (r.time > last_start - 1e-9 * plan.period) res.last_cycle.push_back(r);

  if (write) {
    if (last_checkpoint_step != step) checkpoint(dt);
    flush_csv();
    // Summary.
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
    j["time"] = {{"cycles", plan.cycles}, {"period_s", plan.period}, {"steps", step},
                 {"steps_per_cycle", plan.steps_per_cycle}, {"dt_s", plan.dt > 0 ? plan.dt : dt},
                 {"end_time_s", solver.time()}, {"restarted_from", res.restarted_from},
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
    write_file_atomic(o.directory + "/run.json", j.dump(2) + "\n");
  }
  if (log)
    *log << fmt::format("  done: {} steps in {}, {:.3g} s per step ({:.0f} ns per cell per step)\n",
                        step - res.start_step, fmt_seconds(res.wall_seconds), res.seconds_per_step,
                        1e9 * res.seconds_per_step / res.cells);
  return res;
}

// ---- AeroModel -------------------------------------------------------------------------------------------------

WrenchHistory CfdModel::run(const Insect& insect, const Kinematics& kin, const BodyMotion& motion,
                            const AeroRunOptions& options) const {
  Case c = case_;
  c.insect = insect;
  CfdRunOptions o;
  o.cycles = std::max(1, options.cycles);
  const int run = ++runs_;
  if (log_)
    *log_ << fmt::format("cfd model: run {} ({} wingbeats), body velocity ({:.4g}, {:.4g}, {:.4g}) m/s, rates "
                         "({:.4g}, {:.4g}, {:.4g}) rad/s ...\n",
                         run, o.cycles, motion.velocity.x(), motion.velocity.y(), motion.velocity.z(),
                         motion.rate.x(), motion.rate.y(), motion.rate.z())
          << std::flush;
  const auto t0 = std::chrono::steady_clock::now();
  const CfdResult r = run_cfd(c, kin, motion, o);
  if (log_)
    *log_ << fmt::format("cfd model: run {} done in {:.1f} s\n", run,
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count())
          << std::flush;
  const double T = r.plan.period, start = (r.plan.cycles - 1) * T;
  if (r.last_cycle.empty() || r.last_cycle.back().time - start < 1e-9 * T)
    throw SolveError("cfd model: the run produced no loads");
  // Phase times of the last wingbeat's rows in (0, T], extended periodically, resampled equally spaced.
  std::vector<std::pair<double, WrenchSample>> pts;
  for (const auto& row : r.last_cycle) {
    if (row.time - start < 1e-9 * T) continue;  // the wingbeat's start row: the same phase as its end
    WrenchSample w;
    const auto wr = [&](int i) {
      const auto& q = row.part[i];
      return Wrench{q.pressure_force + q.viscous_force, q.pressure_moment + q.viscous_moment};
    };
    w.body = wr(0);
    w.right = wr(1);
    w.left = wr(2);
    w.power = row.wing_power;
    pts.emplace_back(row.time - start, w);
  }
  const int n = options.samples_per_cycle > 0 ? options.samples_per_cycle
                : r.plan.steps_per_cycle > 0   ? r.plan.steps_per_cycle
                                               : 64;
  auto lerp = [](const WrenchSample& a, const WrenchSample& b, double f) {
    WrenchSample w;
    w.body = (1 - f) * a.body + f * b.body;
    w.right = (1 - f) * a.right + f * b.right;
    w.left = (1 - f) * a.left + f * b.left;
    w.power = (1 - f) * a.power + f * b.power;
    return w;
  };
  WrenchHistory h;
  for (int j = 0; j < n; ++j) {
    const double tau = T * j / n;
    // Bracket tau among the points, the last one carried back by a period before the first.
    std::pair<double, WrenchSample> lo{pts.back().first - T, pts.back().second}, hi = pts.front();
    for (std::size_t k = 0; k < pts.size(); ++k) {
      if (pts[k].first >= tau - 1e-12 * T) {
        hi = pts[k];
        if (k > 0) lo = pts[k - 1];
        break;
      }
      lo = pts[k];
      hi = {pts.front().first + T, pts.front().second};
    }
    const double f = hi.first > lo.first ? (tau - lo.first) / (hi.first - lo.first) : 1.0;
    WrenchSample w = lerp(lo.second, hi.second, std::clamp(f, 0.0, 1.0));
    w.time = tau;
    h.samples.push_back(w);
  }
  return h;
}

}  // namespace flapstab::ns
