// The time step: three Runge-Kutta stages, each a predictor, a pressure Poisson solve and a projection.
#include "cfd/navier_stokes/solver.hpp"
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <fmt/format.h>

namespace flapstab::ns {

namespace {

// Low-storage RK3 (Wray 1990; Spalart, Moser & Rogers 1991, J Comput Phys 96:297): stage k advances by
// dt (gamma_k N_k + zeta_k N_{k-1}); the stages end at t + dt (8/15, 2/3, 1).
constexpr StageCoefficients rk3[3] = {{8.0 / 15.0, 0.0}, {5.0 / 12.0, -17.0 / 60.0}, {3.0 / 4.0, -5.0 / 12.0}};
constexpr double rk3_end[3] = {8.0 / 15.0, 2.0 / 3.0, 1.0};

}  // namespace

Solver::Solver(Grid grid, Boundaries bc, SolverOptions opt, std::shared_ptr<const Decomposition> dec)
    : dec_(dec ? std::move(dec) : std::make_shared<const Decomposition>()), slab_(Multigrid::rank_slab(grid, *dec_)),
      whole_(grid), grid_(grid.slice_z(slab_)), window_grid_(grid_), bc_(bc.local(slab_)), pbc_(bc_.pressure()),
      opt_(opt),
      poisson_(grid, bc.pressure(), dec_), u_(grid_.shape()), ustar_(grid_.shape()), rhs_u_(grid_.shape()),
      p_(grid_.shape()), div_(grid_.shape()), phi_(grid_.shape()), flags_(grid_.shape().size(), CellFlag::fluid) {
  bc.check(grid);
  bc_.check(grid_);
  slabs_ = dec_->distributed()
               ? dec_->slabs(grid.axis[2].n, Multigrid::z_unit(grid, dec_->size()), grid.axis[2].periodic)
               : std::vector<Slab>{slab_};
  // The hooks' window: hook_halo more planes at each cut (its fields come with the hooks). It needs a z axis that is
  // not periodic and neighbours of at least hook_halo + 1 planes; attach() refuses hooks otherwise.
  windowed_ = dec_->distributed() && window_problem(slabs_, grid.axis[2].periodic).empty();
  if (windowed_) {
    const int lo = slab_.cut_lo ? hook_halo : 0, hi = slab_.cut_hi ? hook_halo : 0;
    window_grid_ = grid.slice_z(Slab{slab_.offset - lo, slab_.n + lo + hi, slab_.cut_lo, slab_.cut_hi});
  }
  viscous_rate_ = dec_->max(max_viscous_rate(grid_, opt_.nu));
  if (!(opt_.nu >= 0)) throw std::invalid_argument("navier_stokes solver: viscosity nu must be >= 0");
  if (!(opt_.cfl > 0) || !(opt_.diffusion > 0)) throw std::invalid_argument("navier_stokes solver: cfl and diffusion limits must be > 0");
  if (opt_.cfl > std::sqrt(3.0) || opt_.diffusion > 0.63)
    throw std::invalid_argument("navier_stokes solver: cfl <= sqrt(3) and diffusion <= 0.63 (RK3 stability), got cfl " +
                                std::to_string(opt_.cfl) + ", diffusion " + std::to_string(opt_.diffusion));
  const Sponge& sp = opt_.sponge;
  if (!(sp.rate >= 0) || !std::isfinite(sp.rate))
    throw std::invalid_argument("navier_stokes solver: sponge rate must be >= 0");
  for (int f = 0; f < 6; ++f) {
    const double w = sp.width[std::size_t(f)];
    if (!(w >= 0) || !std::isfinite(w)) throw std::invalid_argument("navier_stokes solver: sponge widths must be >= 0");
    if (w > 0 && bc_.face[std::size_t(f)].type == BC::periodic)
      throw std::invalid_argument("navier_stokes solver: a sponge layer on a periodic face");
  }
  if (sp.active())
    for (int a = 0; a < 3; ++a) {
      const Axis& ax = grid.axis[std::size_t(a)];  // distances from the whole box's faces
      auto sigma = [&](double x) {
        double s = 0;
        for (int side = 0; side < 2; ++side) {
          const double w = sp.width[std::size_t(face(a, side))];
          if (!(w > 0)) continue;
          const double xi = 1 - (side == 0 ? x - ax.lo : ax.hi - x) / w;
          if (xi > 0) s = std::max(s, sp.rate * std::min(xi, 1.0) * std::min(xi, 1.0));
        }
        return s;
      };
      sponge_c_[std::size_t(a)].assign(ax.xc.size(), 0.0);
      sponge_f_[std::size_t(a)].assign(ax.xf.size(), 0.0);
      for (int i = 1; i <= ax.n; ++i) sponge_c_[std::size_t(a)][std::size_t(i)] = sigma(ax.xc[std::size_t(i)]);
      for (int i = 1; i <= ax.n + 1 && std::size_t(i) < ax.xf.size(); ++i)
        sponge_f_[std::size_t(a)][std::size_t(i)] = sigma(ax.xf[std::size_t(i)]);
      if (a == 2 && (slab_.cut_lo || slab_.cut_hi))  // this rank's planes
        for (auto* v : {&sponge_c_[2], &sponge_f_[2]})
          *v = std::vector<double>(v->begin() + slab_.offset, v->begin() + slab_.offset + slab_.n + 2);
    }
  if (sp.active())
    for (int d = 0; d < 3; ++d) {
      const std::vector<double>& sx = (d == 0 ? sponge_f_ : sponge_c_)[0];
      for (int i = 1; i <= grid_.axis[0].n; ++i)
        if (sx[std::size_t(i)] > 0) sponge_band_[std::size_t(d)].push_back(i);
    }
}

// Calls fn(n, sigma, u_far) for every interior unknown n of component d inside a layer (flat index of the field),
// sigma the layer's rate there and u_far the far field's component d; rows in parallel.
template <class Fn>
void Solver::sweep_sponge(int d, const Vec3& rate, Fn&& fn) const {
  const Shape s = grid_.shape();
  const Vec3 stream = opt_.sponge.velocity;
  const double* sx = (d == 0 ? sponge_f_ : sponge_c_)[0].data();
  const double* sy = (d == 1 ? sponge_f_ : sponge_c_)[1].data();
  const double* sz = (d == 2 ? sponge_f_ : sponge_c_)[2].data();
  const double* cx = (d == 0 ? grid_.axis[0].xf : grid_.axis[0].xc).data();
  const double* cy = (d == 1 ? grid_.axis[1].xf : grid_.axis[1].xc).data();
  const double* cz = (d == 2 ? grid_.axis[2].xf : grid_.axis[2].xc).data();
  // u_far[d] = stream[d] - (Omega x r)[d] = stream[d] - sum_a g[a] r[a]
  double g[3];
  for (int a = 0; a < 3; ++a) g[a] = rate.cross(Vec3::Unit(a))[d];
  const std::vector<int>& band = sponge_band_[std::size_t(d)];  // a row's points where neither y nor z is in one
#pragma omp parallel for schedule(static)
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j) {
      const double syz = std::max(sy[j], sz[k]);
      const double base = stream[d] - g[1] * cy[j] - g[2] * cz[k];
      const std::ptrdiff_t row = s(0, j, k);
      auto one = [&](int i) { fn(row + i, std::max(sx[i], syz), base - g[0] * cx[i]); };
      if (syz > 0)
        for (int i = 1; i <= s.nx; ++i) one(i);
      else
        for (int i : band) one(i);
    }
}

// u* <- (u* + alpha dt sigma u_far) / (1 + alpha dt sigma) at every interior unknown where sigma > 0: the implicit
// Euler step of du/dt = -sigma (u - u_far) over the stage's alpha dt (the stages' alphas sum to 1).
void Solver::relax(VectorField& ustar, double adt, double t) const {
  if (sponge_c_[0].empty()) return;
  for (int d = 0; d < 3; ++d) {
    real* u = ustar[d].data();
    sweep_sponge(d, opt_.rate_at(t), [&](std::ptrdiff_t n, double sigma, double target) {
      u[n] = (u[n] + adt * sigma * target) / (1 + adt * sigma);
    });
  }
}

void Solver::sponge_force(const VectorField& u, VectorField& f) const {
  for (int d = 0; d < 3; ++d) {
    f[d].fill(0);
    if (sponge_c_[0].empty()) continue;
    const real* v = u[d].data();
    real* out = f[d].data();
    sweep_sponge(d, opt_.rate_at(t_),
                 [&](std::ptrdiff_t n, double sigma, double target) { out[n] = -sigma * (v[n] - target); });
  }
}

void Solver::initialise(const std::function<Vec3(double, double, double)>& u0, double t0,
                        const std::function<double(double, double, double)>& p0) {
  const Shape s = grid_.shape();
  for (int d = 0; d < 3; ++d)
    for (int k = 0; k <= s.nz + 1; ++k)
      for (int j = 0; j <= s.ny + 1; ++j)
        for (int i = 0; i <= s.nx + 1; ++i) {
          const auto x = grid_.point(d, i, j, k);
          ustar_[d](i, j, k) = u0(x[0], x[1], x[2])[d];
        }
  p_.fill(0);
  if (p0)
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const auto x = grid_.centre(i, j, k);
          p_(i, j, k) = p0(x[0], x[1], x[2]);
        }
  fill_ghosts(p_, pbc_);
  dec_->exchange(p_, slab_);
  t_ = t0;
  impose_normal_velocity(ustar_, bc_, t_, &grid_);
  exchange(ustar_);
  divergence(grid_, ustar_, div_, 1.0);
  PoissonOptions popt = opt_.poisson;
  popt.rtol = std::min(popt.rtol, 1e-10);
  poisson_.solve(phi_[0], div_, popt);
  Field discard(grid_.shape());
  project(grid_, ustar_, phi_[0], u_, discard, 1.0);
  guess_ = false;
  fill_velocity_ghosts(u_, bc_, t_, &grid_);
  exchange(u_);
  for (int d = 0; d < 3; ++d) rhs_u_[d].fill(0);
  if (windowed_ && hooks_) refresh_window();  // hook_velocity() and hook_pressure() before the first step
}

void Solver::refresh_window() {
  for (int d = 0; d < 3; ++d) widen(u_[d], wu_[d]);
  widen(p_, wp_);
}

void Solver::exchange(VectorField& u) const {
  for (int d = 0; d < 3; ++d) dec_->exchange(u[d], slab_);
}

void Solver::attach(StageHooks* hooks) {
  if (hooks && dec_->distributed())
    if (const std::string why = window_problem(slabs_, whole_.axis[2].periodic); !why.empty())
      throw std::invalid_argument("navier_stokes solver: " + why + ": use fewer ranks or more z cells");
  hooks_ = hooks;
  if (hooks_ && windowed_) {  // the window's fields, allocated once and filled from the current state
    const Shape ws = window_grid_.shape();
    if (!(wp_.shape() == ws)) {
      wu_ = VectorField(ws);
      wp_ = Field(ws);
      wflags_.assign(ws.size(), CellFlag::fluid);
    }
    refresh_window();
  }
}

std::string Solver::window_problem(const std::vector<Slab>& slabs, bool z_periodic) {
  if (slabs.size() < 2) return "";
  if (z_periodic) return "immersed bodies over several MPI ranks need a z axis that is not periodic";
  for (const Slab& s : slabs)
    if (s.n < hook_halo + 1)
      return fmt::format("immersed bodies over MPI ranks need slabs of at least {} planes (a rank would hold {} of "
                         "the {})",
                         hook_halo + 1, s.n, slabs.back().offset + slabs.back().n);
  return "";
}

std::string Solver::split_problem(const Grid& whole, int ranks, bool hooks) {
  if (ranks < 2) return "";
  try {
    const std::vector<Slab> slabs = Decomposition::slabs_of(whole.axis[2].n, Multigrid::z_unit(whole, ranks), ranks,
                                                            whole.axis[2].periodic);
    return hooks ? window_problem(slabs, whole.axis[2].periodic) : std::string();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
}

void Solver::keep_own(const Field& w, Field& f) const {
  const Shape& s = f.shape();
  const int lo = slab_.cut_lo ? hook_halo : 0;
  std::copy_n(w.data() + w.shape()(0, 0, lo + 1), std::size_t(s.nz) * std::size_t(s.sz), f.data() + s(0, 0, 1));
}

namespace {
// Largest ratio of a cell's longest to its shortest side.
double max_aspect_ratio(const Grid& g) {
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {0, 0, 0};
  for (int a = 0; a < 3; ++a)
    for (int i = 1; i <= g.axis[std::size_t(a)].n; ++i) {
      lo[a] = std::min(lo[a], g.axis[std::size_t(a)].dc[std::size_t(i)]);
      hi[a] = std::max(hi[a], g.axis[std::size_t(a)].dc[std::size_t(i)]);
    }
  double r = 1;  // over the tensor-product cells: the longest side of one axis against the shortest of another
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) r = std::max(r, hi[a] / lo[b]);
  return r;
}
}  // namespace

double Solver::stable_dt() const { return time_step(dec_->max(max_rate(grid_, u_))); }

// conv: max over cells of sum_a |u_a| / dx_a.
double Solver::time_step(double conv) const {
  const double visc = viscous_rate_;
  if (opt_.dt > 0) {
    // A fixed step beyond RK3's stability region blows up within a few steps: say so now instead.
    if (opt_.dt * visc > 0.63 || opt_.dt * conv > std::sqrt(3.0))
      throw std::runtime_error("navier_stokes solver: fixed dt = " + std::to_string(opt_.dt) +
                               " is unstable (RK3 needs CFL <= 1.73 and diffusion number <= 0.63; CFL " +
                               std::to_string(opt_.dt * conv) + ", diffusion number " + std::to_string(opt_.dt * visc) +
                               "); reduce dt to " + std::to_string(std::min(opt_.cfl / conv, opt_.diffusion / visc)));
    return opt_.dt;
  }
  double dt = opt_.dt_max;
  if (conv > 0) dt = std::min(dt, opt_.cfl / conv);
  if (visc > 0) dt = std::min(dt, opt_.diffusion / visc);
  if (!std::isfinite(dt) || !(dt > 0))
    throw std::runtime_error("navier_stokes solver: no finite stable time step (flow at rest and nu = 0: set dt or dt_max)");
  return dt;
}

// Predict, impose the box (then body) velocity, project with (alpha dt), refresh ghosts: on return u is
// discretely divergence-free to the Poisson tolerance and BC-consistent at t_stage, ready for the next stage.
void Solver::stage(double dt, const StageCoefficients& c, double t_stage) {
  const double adt = c.alpha() * dt;
  predict(grid_, u_, p_, rhs_u_, ustar_, opt_.nu, dt, c);
  // A turning frame: Coriolis at the stage's starting rate (like the convection), and the Euler acceleration's
  // integral over the stage where the rate changes.
  const Vec3 from = opt_.rate_at(t_stage - adt), to = opt_.rate_at(t_stage);
  if (from.squaredNorm() > 0) add_coriolis(grid_, u_, rhs_u_, ustar_, from, dt, c);
  if (from != to) add_rotation(grid_, ustar_, from - to);
  relax(ustar_, adt, t_stage);
  impose_normal_velocity(ustar_, bc_, t_stage, &grid_);
  dec_->exchange(ustar_[2], slab_);  // the divergence of a slab's top cells reads the face above (the next rank's)
  if (hooks_ && windowed()) {  // the hooks force the window; this rank keeps its planes
    for (int d = 0; d < 3; ++d) widen(ustar_[d], wu_[d]);
    hooks_->after_predictor(wu_, t_stage, adt);
    for (int d = 0; d < 3; ++d) keep_own(wu_[d], ustar_[d]);
    exchange(ustar_);
  } else if (hooks_) {
    hooks_->after_predictor(ustar_, t_stage, adt);
  }
  divergence(grid_, ustar_, div_, 1.0 / adt);
  // Besides the relative tolerance, stop at a divergence of 1e-12 of the velocity-gradient scale: no round-off chase.
  PoissonOptions popt = opt_.poisson;
  popt.atol = std::max(popt.atol, 1e-12 * rate_ / adt);
  Field& phi = phi_[stage_];
  stats_.push_back(poisson_.solve(phi, div_, popt, guess_));
  const PoissonStats& ps = stats_.back();
  if (ps.breakdown)
    throw std::runtime_error("navier_stokes solver: the pressure solve broke down on non-finite values at t = " +
                             std::to_string(t_stage) + " (time step too large? CFL was " + std::to_string(cfl(dt)) + ")");
  ++solves_;
  if (!ps.converged) {
    ++unconverged_;
    worst_unconverged_ = std::max(worst_unconverged_, ps.target > 0 ? ps.residual / ps.target : 0.0);
    if (ps.residual >= ps.initial_residual)
      throw std::runtime_error(fmt::format(
          "navier_stokes solver: the pressure solve ({}) diverged at t = {:.6g}: after {} iterations the divergence "
          "residual is {:.3g}, no smaller than at the start ({:.3g}); {} of the {} pressure solves so far stopped above "
          "their tolerance. {}",
          popt.backend == PoissonBackend::hypre ? "hypre" : "multigrid", t_stage, ps.cycles, ps.residual,
          ps.initial_residual, unconverged_, solves_,
          popt.backend == PoissonBackend::hypre
              ? fmt::format("The flow itself may be diverging (CFL {:.3g}): reduce the time step", cfl(dt))
              : fmt::format("Cells much longer in one direction than in another (largest aspect ratio here {:.3g}) "
                            "defeat the multigrid's point smoother: reduce the stretching or the domain size, or use "
                            "[aero.cfd] pressure_solver = \"hypre\"; or the flow itself is diverging (CFL {:.3g})",
                            max_aspect_ratio(grid_), cfl(dt))));
  }
  project(grid_, ustar_, phi, u_, p_, adt);
  fill_ghosts(p_, pbc_);
  fill_velocity_ghosts(u_, bc_, t_stage, &grid_);
  dec_->exchange(p_, slab_);
  exchange(u_);
  after_projection(t_stage, stage_ == 2);
  if (opt_.keep_stage_velocities && stage_ < 2)
    for (int d = 0; d < 3; ++d) stage_u_[std::size_t(stage_)][d] = u_[d];
}

void Solver::after_projection(double t, bool read_after) {
  if (!windowed()) {
    if (hooks_) hooks_->after_projection(u_, p_, t);
    return;
  }
  if (!hooks_) return;  // a flow without bodies needs no window
  // the velocity window: what the hook reads, or what hook_velocity() gives the loads after the step
  if (read_after || hooks_->reads_projected_velocity())
    for (int d = 0; d < 3; ++d) widen(u_[d], wu_[d]);
  widen(p_, wp_);
  hooks_->after_projection(wu_, wp_, t);
  keep_own(wp_, p_);
  fill_ghosts(p_, pbc_);
  dec_->exchange(p_, slab_);
  widen(p_, wp_);  // the overlap as its owners left it (what the loads read)
}

double Solver::step() {
  const double conv = dec_->max(max_rate(grid_, u_));
  const double dt = time_step(conv);
  rate_ = std::max(conv, viscous_rate_);
  stats_.clear();
  stages_kept_ = false;
  for (stage_ = 0; stage_ < 3; ++stage_) stage(dt, rk3[stage_], t_ + rk3_end[stage_] * dt);
  stages_kept_ = opt_.keep_stage_velocities;
  dt_last_ = dt;
  guess_ = true;
  t_ += dt;
  if (dec_->max(std::isfinite(p_(1, 1, 1)) && std::isfinite(u_[0](1, 1, 1)) ? 0.0 : 1.0) > 0)
    throw std::runtime_error("navier_stokes solver: the solution is not finite at t = " + std::to_string(t_) +
                             " (time step too large? CFL was " + std::to_string(cfl(dt)) + ")");
  return dt;
}

void Solver::restore(double t, const VectorField& u, const Field& p, const VectorField& phi, bool guess) {
  const Shape s = grid_.shape();
  for (int d = 0; d < 3; ++d)
    if (!(u[d].shape() == s) || !(phi[d].shape() == s))
      throw std::invalid_argument("navier_stokes solver: restored fields do not match the grid");
  if (!(p.shape() == s)) throw std::invalid_argument("navier_stokes solver: restored pressure does not match the grid");
  u_ = u;
  p_ = p;
  phi_ = phi;
  guess_ = guess;
  t_ = t;
  stages_kept_ = false;
  for (int d = 0; d < 3; ++d) rhs_u_[d].fill(0);  // the first RK3 stage does not read it (zeta_1 = 0)
  fill_ghosts(p_, pbc_);
  fill_velocity_ghosts(u_, bc_, t_, &grid_);
  dec_->exchange(p_, slab_);
  exchange(u_);
  after_projection(t_, true);
}

const VectorField& Solver::stage_velocity(int k) const {
  if (!stages_kept_ || k < 0 || k > 1)
    throw std::logic_error("navier_stokes solver: stage_velocity(" + std::to_string(k) +
                           ") without a kept stage (SolverOptions::keep_stage_velocities, k = 0 or 1, after a step)");
  return stage_u_[std::size_t(k)];
}

StageCoefficients Solver::stage_coefficients(int k) {
  if (k < 0 || k > 2) throw std::out_of_range("navier_stokes solver: RK3 stage " + std::to_string(k));
  return rk3[k];
}

std::size_t Solver::bytes() const {
  // u, u*, N_prev, phi (3 each), p, div, the kept stage velocities (6), and the Poisson solver's vectors and levels.
  return (14 + (opt_.keep_stage_velocities ? 6 : 0)) * grid_.shape().size() * sizeof(real) + poisson_.bytes() +
         flags_.size() * sizeof(CellFlag);
}

}  // namespace flapstab::ns
