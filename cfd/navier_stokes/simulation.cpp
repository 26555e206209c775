// The stepping CFD simulation (simulation.hpp).
#include "cfd/navier_stokes/simulation.hpp"
#include "cfd/navier_stokes/solver_io.hpp"
#include "cfd/navier_stokes/poisson_hypre.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <fmt/format.h>
#include <omp.h>

#include "cfd/navier_stokes/geometry.hpp"
#include "cfd/navier_stokes/insect_motion.hpp"
#include "cfd/navier_stokes/operators.hpp"
#include "core/configuration.hpp"

namespace flapstab::ns {

namespace {

// The RK3 scheme with central fluxes is stable to CFL sqrt(3).
constexpr double rk3_cfl_limit = 1.7320508075688772;

// The still air far away seen from the body's frame: the uniform stream -V, plus -Omega x r when it turns.
// With a frame rotation, -V - Omega(t) x r.
Boundaries far_field(const BodyMotion& motion, const SimulationOptions::FrameRotation& rotation) {
  Boundaries bc;
  const Vec3 stream = -motion.velocity;
  std::function<Vec3(double)> rate = rotation.rate;
  if (!rate && motion.rate.norm() > 0) rate = [w = motion.rate](double) { return w; };
  for (int f = 0; f < 6; ++f) {
    bc.face[std::size_t(f)].type = BC::velocity;
    if (stream.norm() > 0) bc.face[std::size_t(f)].velocity = [stream](double) { return stream; };
    if (rate)
      bc.face[std::size_t(f)].field = [stream, rate](double t, const Vec3& x) { return Vec3(stream - rate(t).cross(x)); };
  }
  bc.face[std::size_t(face(2, 1))] = FaceCondition{BC::outflow, {}, {}};
  return bc;
}

// Volume, first and second moments (about the grid origin) of the solid a closed mesh bounds.
struct VolumeMoments {
  double volume = 0;
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();
};
VolumeMoments volume_moments(const TriangleMesh& m) {
  VolumeMoments v;
  for (std::size_t t = 0; t < m.size(); ++t) {
    const Vec3 a = m.vertex(t, 0), b = m.vertex(t, 1), c = m.vertex(t, 2);
    const double det = a.dot(b.cross(c));  // 6 x the signed volume of the tetrahedron (0, a, b, c)
    const Vec3 sum = a + b + c;
    v.volume += det / 6;
    v.first += det / 24 * sum;
    v.second += det / 120 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose());
  }
  return v;
}

SolverOptions solver_options(const CfdSettings& s, const CfdPlan& plan, const BodyMotion& m,
                             const SimulationOptions& o, const std::string& path) {
  const SimulationOptions::FrameRotation& rotation = o.frame_rotation;
  SolverOptions so;
  if (o.pressure_rtol > 0) so.poisson.rtol = o.pressure_rtol;
  so.nu = plan.nu;
  so.cfl = s.cfl;
  so.dt = plan.dt;
  so.frame_rate = m.rate;
  so.frame_rate_at = rotation.rate;
  // the partition with the forced region as the body takes its terms from the last stage's velocities
  so.keep_stage_velocities = s.fpm.enabled && s.fpm.body == "forced-region";
  const double speed = plan.tip_speed_max + plan.body_speed_max;
  so.dt_max = speed > 0 ? s.cfl * plan.h_actual / speed : plan.period / 100;
  if (plan.sponge_width > 0) {
    for (std::size_t f = 0; f < 6; ++f) so.sponge.width[f] = plan.sponge_faces[f] ? plan.sponge_width : 0;
    so.sponge.rate = plan.sponge_rate;
    so.sponge.velocity = -m.velocity;  // with so.frame_rate: the far field -V - Omega x r the faces prescribe
  }
  if (s.pressure_solver == "hypre") {
    if (!hypre_available())
      throw InputError(path, "aero.cfd.pressure_solver", "\"hypre\", but this flapstab was built without hypre",
                       "\"multigrid\" (or install libhypre-dev and libopenmpi-dev and rebuild)");
    so.poisson.backend = PoissonBackend::hypre;
  }
  return so;
}

}  // namespace

struct Simulation::Impl : StageHooks {
  Configuration config;
  InsectMotion motion;
  Solver solver;
  std::optional<ImmersedBoundary> ib;
  bool exchange = false;
  CfdLoadRow row;
  bool have_row = false;
  // Volume moments of the closed parts (the body: fixed in the body's frame, so computed once).
  std::vector<std::optional<VolumeMoments>> closed;
  int parts = 3;  // parts of the geometry (insect_part_count): the loads' rows carry as many
  Simulation::PartSource source;  // a driver's part kinematics (free flight), else the prescribed motion
  SimulationOptions::FrameRotation rotation;  // a frame whose rate changes in time, else none
  std::vector<PartState> parts_at(double t) const {
    if (source) return source(t);
    std::vector<PartState> out = motion.parts(t);
    if (rotation.rate) {
      const Vec3 w = rotation.rate(t), wdot = rotation.rate_rate(t);
      for (PartState& p : out) p.frame_rate = w, p.frame_rate_rate = wdot;
    }
    return out;
  }
  // The frame's rate at t (rad/s): the rotation's, or the steady body rate's.
  Vec3 frame_rate(double t) const { return rotation.rate ? rotation.rate(t) : motion.body_motion().rate; }

  double rho = 0;
  Impl(const Case& c, const Kinematics& kin, const BodyMotion& m, const CfdPlan& plan, const SimulationOptions& o)
      : config(c.insect, kin), motion(config, m),
        solver(plan_grid(plan), far_field(m, o.frame_rotation),
               solver_options(c.aero.cfd, plan, m, o, c.path), o.decomposition),
        parts(insect_part_count(c.insect)), rotation(o.frame_rotation), rho(plan.rho) {
    if (rotation.rate && (!rotation.rate_rate || m.rate.squaredNorm() > 0))
      throw std::logic_error("Simulation: a frame rotation needs rate and rate_rate, and no steady body rate");
    if (o.initial_velocity) solver.initialise([&](double x, double y, double z) { return o.initial_velocity(x, y, z); });
    else solver.initialise([this](double x, double y, double z) { return motion.far_field(Vec3(x, y, z)); });
    if (o.bodies) {
      const InsectSurfaces surfaces(config, mesh_resolution(c.aero.cfd));
      ib.emplace(solver.hook_grid(), ImmersedOptions{.density = plan.rho, .contact = o.contact});
      const auto start = motion.parts(0.0);
      const std::size_t n = surfaces.reference().size();
      for (std::size_t i = 0; i < n; ++i) ib->add_part(surfaces.reference()[i], start[i]);
      exchange = c.aero.cfd.loads == "exchange";
      closed.resize(n);
      for (std::size_t i = 0; i < n; ++i)
        if (!surfaces.reference()[i].membrane) closed[i] = volume_moments(surfaces.reference()[i].transformed(start[i].pose));
      attach();
    }
  }
  // Places the parts at the solver's time, marks the flags and routes the solver's stages through this.
  void attach() {
    ib->set_parts(solver.time(), parts_at(solver.time()));
    ib->attach(solver);
    solver.attach(this);
  }
  void after_predictor(VectorField& ustar, double t, double alpha_dt) override {
    ib->set_parts(t, parts_at(t));
    ib->after_predictor(ustar, t, alpha_dt);
  }
  void after_projection(VectorField& u, Field& p, double t) override { ib->after_projection(u, p, t); }
  bool reads_projected_velocity() const override { return ib->reads_projected_velocity(); }

  CfdLoadRow compute_row(double period, long step) const {
    CfdLoadRow r;
    const double tb = solver.time();
    r.time = tb;
    r.step = step;
    r.phase = tb / period - std::floor(tb / period + 1e-12);
    if (r.phase < 0) r.phase = 0;
    r.parts = parts;
    if (!ib) return r;
    const auto loads = exchange ? ib->exchange_loads(solver, Vec3::Zero()) : ib->loads(solver, Vec3::Zero());
    const auto states = parts_at(tb);
    const Vec3 W = frame_rate(tb);
    for (int i = 0; i < parts; ++i) {
      const PartLoads& L = loads[std::size_t(i)];
      auto& q = r.part[i];
      q.pressure_force = L.pressure_force;
      q.viscous_force = L.viscous_force;
      q.pressure_moment = L.pressure_moment;
      q.viscous_moment = L.viscous_moment;
      q.power = L.power;
      if (W.squaredNorm() > 0) {
        // In a turning frame the solver's pressure is the reduced one, P = p - rho |Omega x r|^2 / 2: on a closed
        // part the centrifugal pressure adds rho int_V Omega x (Omega x r) dV to the force and rho (S Omega) x Omega
        // to the moment about O (S = int_V r r^T dV). Membranes enclose no volume.
        if (const auto& v = closed[std::size_t(i)]) {
          q.pressure_force += rho * W.cross(W.cross(v->first));
          q.pressure_moment += rho * (v->second * W).cross(W);
        }
      }
      if (i > 0) {  // a wing's (either pair's) work through its motion relative to the body: -(F . v_c + M_c . omega)
        const RigidVelocity& g = states[std::size_t(i)].velocity;
        const Vec3 F = L.force(), Mc = L.moment() - g.centre.cross(F);
        r.wing_power += -(F.dot(g.velocity) + Mc.dot(g.omega));
      }
    }
    return r;
  }
};

Simulation::Simulation(const Case& c, const Kinematics& kin, const BodyMotion& motion, const CfdPlan& plan,
                       SimulationOptions options)
    : case_(c), kin_(kin), motion_(motion), plan_(plan) {
  check_memory(plan_, c.path);  // before anything large is allocated
  if (c.aero.cfd.threads > 0) omp_set_num_threads(c.aero.cfd.threads);
  impl_ = std::make_unique<Impl>(case_, kin_, motion_, plan_, options);
}

Simulation::~Simulation() = default;

const Grid& Simulation::grid() const { return impl_->solver.grid(); }
const Solver& Simulation::solver() const { return impl_->solver; }
double Simulation::time() const { return impl_->solver.time(); }
std::size_t Simulation::cells() const { return impl_->solver.whole_grid().cells(); }
const Grid& Simulation::whole_grid() const { return impl_->solver.whole_grid(); }
std::size_t Simulation::bytes() const { return impl_->solver.bytes() + (impl_->ib ? impl_->ib->bytes() : 0); }
bool Simulation::has_bodies() const { return impl_->ib.has_value(); }
const ImmersedBoundary* Simulation::immersed() const { return impl_->ib ? &*impl_->ib : nullptr; }
int Simulation::part_count() const { return impl_->parts; }
std::vector<PartState> Simulation::part_states() const {
  if (!impl_->ib) return {};
  return impl_->parts_at(time());
}
std::vector<PartState> Simulation::prescribed_parts(double t) const {
  if (!impl_->ib) return {};
  return impl_->motion.parts(t);
}
void Simulation::set_part_source(PartSource source) {
  Impl& m = *impl_;
  if (source && (motion_.velocity.squaredNorm() > 0 || motion_.rate.squaredNorm() > 0 || m.rotation.rate))
    throw std::logic_error("Simulation::set_part_source: the simulation was planned with a body motion");
  m.source = std::move(source);
  if (m.ib) {
    m.solver.attach(nullptr);
    m.attach();
  }
  m.have_row = false;
}
double Simulation::part_volume(int part, Vec3* centroid) const {
  const auto& c = impl_->closed.at(std::size_t(part));
  if (!c || c->volume <= 0) {
    if (centroid) *centroid = Vec3::Zero();
    return 0;
  }
  if (centroid) *centroid = c->first / c->volume;
  return c->volume;
}

void Simulation::restore(const SimulationState& whole_or_slab, const BodyMotion& state_motion) {
  const SimulationState s = own_planes(whole_or_slab, impl_->solver);
  const Shape sh = grid().shape();
  if (!(s.u[0].shape() == sh))
    throw std::invalid_argument("Simulation::restore: the state's grid shape differs from the simulation's");
  const Vec3 rate = impl_->frame_rate(s.time);  // this run's frame rate at the state's time
  if (state_motion.velocity == motion_.velocity && state_motion.rate == rate) return restore(s);
  // The state's far field -V0 - Omega0 x r becomes this run's: add the difference everywhere (a linear field,
  // divergence-free, so the restored velocity stays discretely divergence-free).
  const Vec3 dV = motion_.velocity - state_motion.velocity, dW = rate - state_motion.rate;
  SimulationState t = s;
  const Grid& g = grid();
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k <= sh.nz + 1; ++k)
      for (int j = 0; j <= sh.ny + 1; ++j)
        for (int i = 0; i <= sh.nx + 1; ++i) {
          const auto x = g.point(d, i, j, k);
          t.u[d](i, j, k) += real((-dV - dW.cross(Vec3(x[0], x[1], x[2])))[d]);
        }
  restore(t);
}

void Simulation::restore(const SimulationState& whole_or_slab) {
  const SimulationState s = own_planes(whole_or_slab, impl_->solver);
  const Shape sh = grid().shape();
  if (!(s.u[0].shape() == sh))
    throw std::invalid_argument("Simulation::restore: the state's grid shape differs from the simulation's");
  Impl& m = *impl_;
  m.solver.attach(nullptr);
  m.solver.restore(s.time, s.u, s.p, s.phi, s.guess);
  if (m.ib) m.attach();
  step_ = s.step;
  dt_last_ = s.dt_last;
  m.have_row = false;
}

SimulationState Simulation::state() const {
  const Solver& sv = impl_->solver;
  SimulationState s;
  s.time = sv.time();
  s.step = step_;
  s.dt_last = dt_last_;
  s.u = sv.velocity();
  s.p = sv.pressure();
  s.phi = sv.pressure_increments();
  s.guess = sv.has_guess();
  return s;
}

SimulationState Simulation::whole_state() const {
  if (!impl_->solver.decomposition().distributed()) return state();
  return gather_state(impl_->solver, step_, dt_last_);
}

StepReport Simulation::advance() {
  Impl& m = *impl_;
  StepReport r;
  r.t_before = m.solver.time();
  try {
    r.dt = m.solver.step();
  } catch (const std::exception& e) {
    throw StepFailure(step_ + 1, r.t_before, e.what());
  }
  ++step_;
  dt_last_ = r.dt;
  r.step = step_;
  r.time = m.solver.time();
  r.row = m.compute_row(plan_.period, step_);
  bool finite = std::isfinite(m.solver.kinetic_energy()) && std::isfinite(r.row.wing_power);
  for (int i = 0; i < r.row.parts; ++i) {
    const auto& q = r.row.part[i];
    finite = finite && q.pressure_force.allFinite() && q.viscous_force.allFinite() && q.pressure_moment.allFinite() &&
             q.viscous_moment.allFinite() && std::isfinite(q.power);
  }
  if (!finite) throw StepFailure(step_, r.time, "the solution or the loads are not finite");
  r.cfl = m.solver.cfl(r.dt);
  if (!(r.cfl <= rk3_cfl_limit)) {
    // Where: the cell and its distance from the domain's faces, so that a blow-up at an outflow face is told from
    // one at a wing.
    const Grid& g = m.solver.whole_grid();
    RateLocation at = max_rate_location(m.solver.grid(), m.solver.velocity());
    at.k += m.solver.slab().offset;  // in the whole grid
    if (const Decomposition& D = m.solver.decomposition(); D.distributed()) {
      // the rank with the largest rate (the lowest of equal ones) tells where it is
      const double top = D.max(at.rate);
      const int owner = -int(D.max(at.rate == top ? -double(D.rank()) : -double(D.size())));
      double where[6] = {double(at.i), double(at.j), double(at.k), at.centre.x(), at.centre.y(), at.centre.z()};
      if (D.rank() != owner) std::fill(where, where + 6, 0.0);
      D.sum(where, 6);
      at.i = int(where[0]), at.j = int(where[1]), at.k = int(where[2]);
      at.centre = Vec3(where[3], where[4], where[5]);
      at.rate = top;
    }
    static const char* faces[6] = {"x-", "x+", "y-", "y+", "z-", "z+"};
    int nearest = 0, cells = 1 << 30;
    for (int a = 0; a < 3; ++a) {
      const int idx = a == 0 ? at.i : a == 1 ? at.j : at.k, n = g.axis[std::size_t(a)].n;
      if (idx - 1 < cells) cells = idx - 1, nearest = 2 * a;
      if (n - idx < cells) cells = n - idx, nearest = 2 * a + 1;
    }
    throw StepFailure(step_, r.time,
                      fmt::format("CFL {:.3g} above the RK3 limit 1.73 (the flow blew up), largest in cell ({}, {}, {}) "
                                  "at ({:.4g}, {:.4g}, {:.4g}) m, {} cells from the {} face of the domain",
                                  r.cfl, at.i, at.j, at.k, at.centre.x(), at.centre.y(), at.centre.z(), cells,
                                  faces[nearest]));
  }
  m.row = r.row;
  m.have_row = true;
  return r;
}

CfdLoadRow Simulation::loads() const { return impl_->have_row ? impl_->row : impl_->compute_row(plan_.period, step_); }

TriangleMesh Simulation::surface(int part) const {
  if (!impl_->ib) throw std::logic_error("Simulation::surface: a body-free simulation");
  return impl_->ib->surface(part, time());
}

std::vector<double> Simulation::solid_mask() const {
  if (!impl_->ib) return std::vector<double>(grid().cells(), 0.0);
  std::vector<double> mask = impl_->ib->solid_mask(time());  // the hooks' window: the slab and its halo
  const Solver& sv = impl_->solver;
  if (&sv.hook_grid() == &sv.grid()) return mask;
  const Shape sh = grid().shape();
  const std::size_t plane = std::size_t(sh.nx) * std::size_t(sh.ny);
  std::vector<double> own(grid().cells());
  std::copy_n(mask.begin() + std::ptrdiff_t(plane * std::size_t(sv.hook_first_plane() - 1)), own.size(), own.begin());
  return own;
}

SurfacePressure Simulation::surface_pressure(int part) const {
  if (!impl_->ib) throw std::logic_error("Simulation::surface_pressure: a body-free simulation");
  return impl_->ib->surface_pressure(impl_->solver, part);
}

// ---- state files -----------------------------------------------------------------------------------------------

namespace {

// One field on the lattice of component d (d = -1: cell centres) of grid `from`, at the same lattice of `to`:
// trilinear on the old lattice's interior points (faces 1..n+1 along d, centres 1..n across; bracket clamps to
// them), zero where the point lies beyond the old domain (to rounding).
void transfer_field(const Field& src, const Grid& from, Field& dst, const Grid& to, int d) {
  struct Where {
    int i = 0;
    double w = 0;
    bool outside = false;
  };
  std::array<std::vector<Where>, 3> at;
  for (int a = 0; a < 3; ++a) {
    const Axis& f = from.axis[std::size_t(a)];
    const Axis& t = to.axis[std::size_t(a)];
    const double tol = 1e-9 * (f.hi - f.lo);
    for (int i = 0; i <= t.n + 1; ++i) {
      Where p;
      const double x = a == d ? t.xf[std::size_t(i)] : t.xc[std::size_t(i)];
      if (a == d)
        bracket(f.xf, 1, f.n + 1, x, p.i, p.w);
      else
        bracket(f.xc, 1, f.n, x, p.i, p.w);
      p.outside = x < f.lo - tol || x > f.hi + tol;
      at[std::size_t(a)].push_back(p);
    }
  }
  const Shape sh = dst.shape();
#pragma omp parallel for schedule(static) if (threaded(sh))
  for (int k = 0; k <= sh.nz + 1; ++k)
    for (int j = 0; j <= sh.ny + 1; ++j)
      for (int i = 0; i <= sh.nx + 1; ++i) {
        const Where& px = at[0][std::size_t(i)];
        const Where& py = at[1][std::size_t(j)];
        const Where& pz = at[2][std::size_t(k)];
        if (px.outside || py.outside || pz.outside) {
          dst(i, j, k) = 0;
          continue;
        }
        const int I[3] = {px.i, py.i, pz.i};
        const double W[3] = {px.w, py.w, pz.w};
        dst(i, j, k) = real(trilinear(src, I, W));
      }
}

}  // namespace

SimulationState transfer_state(const SimulationState& s, const Grid& from, const Grid& to) {
  if (!(s.u[0].shape() == from.shape()))
    throw std::invalid_argument("transfer_state: the state's grid shape differs from the source grid's");
  SimulationState r;
  r.time = s.time;
  r.step = s.step;
  r.dt_last = s.dt_last;
  r.u = VectorField(to.shape());
  r.phi = VectorField(to.shape());
  r.p = Field(to.shape());
  r.guess = false;
  for (int d = 0; d < 3; ++d) transfer_field(s.u[d], from, r.u[d], to, d);
  transfer_field(s.p, from, r.p, to, -1);
  return r;
}

CheckpointHeader state_header(double time, long step, double dt_last, bool guess, std::map<std::string, double> values,
                              std::map<std::string, std::string> text) {
  CheckpointHeader h;
  h.time = time;
  h.step = step;
  h.values = std::move(values);
  h.values["dt"] = dt_last;
  h.values["guess"] = guess ? 1.0 : 0.0;
  h.text = std::move(text);
  return h;
}

void write_state(const std::string& path, const Simulation& sim, std::map<std::string, double> values,
                 std::map<std::string, std::string> text) {
  write_state_over_ranks(path, sim.solver(), sim.step(), sim.last_dt(), std::move(values), std::move(text));
}

void write_state(const std::string& path, const SimulationState& s, std::map<std::string, double> values,
                 std::map<std::string, std::string> text) {
  const Shape sh = s.p.shape();
  const CheckpointHeader h = state_header(s.time, s.step, s.dt_last, s.guess, std::move(values), std::move(text));
  std::vector<CheckpointArray> arrays;
  const std::vector<std::size_t> shape = {std::size_t(sh.nz + 2), std::size_t(sh.ny + 2), std::size_t(sh.nx + 2)};
  for (int d = 0; d < 3; ++d)
    arrays.push_back({fmt::format("u{}", d), std::span<const double>(s.u[d].data(), sh.size()), shape});
  arrays.push_back({"p", std::span<const double>(s.p.data(), sh.size()), shape});
  for (int d = 0; d < 3; ++d)
    arrays.push_back({fmt::format("phi{}", d), std::span<const double>(s.phi[d].data(), sh.size()), shape});
  write_checkpoint(path, h, arrays);
}

namespace {

// A state of fields of shape `sh` from a checkpoint of flapstab cfd, each array read by read(name, span).
template <class Read>
SimulationState state_from(const CheckpointReader& ck, const Shape& sh, Read&& read) {
  for (const char* name : {"u0", "u1", "u2", "p", "phi0", "phi1", "phi2"})
    if (!ck.contains(name)) throw InputError(ck.path(), name, "missing array", "a checkpoint of flapstab cfd");
  if (!ck.header().values.count("guess"))
    throw InputError(ck.path(), "guess", "missing value", "a checkpoint of flapstab cfd");
  SimulationState s;
  s.u = VectorField(sh);
  s.phi = VectorField(sh);
  s.p = Field(sh);
  for (int d = 0; d < 3; ++d) {
    read(fmt::format("u{}", d), std::span<double>(s.u[d].data(), sh.size()));
    read(fmt::format("phi{}", d), std::span<double>(s.phi[d].data(), sh.size()));
  }
  read(std::string("p"), std::span<double>(s.p.data(), sh.size()));
  s.time = ck.header().time;
  s.step = long(ck.header().step);
  s.guess = ck.header().values.at("guess") != 0;
  const auto dt = ck.header().values.find("dt");
  s.dt_last = dt != ck.header().values.end() ? dt->second : 0;
  return s;
}

}  // namespace

SimulationState read_state(const CheckpointReader& ck, const Shape& whole, const Slab& slab) {
  const std::vector<std::size_t> dims{std::size_t(whole.nz + 2), std::size_t(whole.ny + 2), std::size_t(whole.nx + 2)};
  for (const char* name : {"u0", "u1", "u2", "p", "phi0", "phi1", "phi2"})
    if (ck.contains(name) && ck.shape(name) != dims)
      throw InputError(ck.path(), name, "array of another grid's shape",
                       fmt::format("{} x {} x {} cells (with ghosts)", whole.nx + 2, whole.ny + 2, whole.nz + 2));
  const std::size_t first = std::size_t(slab.offset);  // padded planes offset .. offset + n + 1
  return state_from(ck, Shape(whole.nx, whole.ny, slab.n),
                    [&](const std::string& name, std::span<double> out) { ck.read_rows(name, first, out); });
}

SimulationState read_state(const CheckpointReader& ck, const Shape& sh) {
  return state_from(ck, sh, [&](const std::string& name, std::span<double> out) { ck.read(name, out); });
}

}  // namespace flapstab::ns
