// Incompressible Navier-Stokes on a non-uniform staggered grid: fractional step, low-storage RK3, multigrid projection.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>
#include "cfd/navier_stokes/boundary.hpp"
#include "cfd/navier_stokes/operators.hpp"
#include "cfd/navier_stokes/poisson.hpp"

namespace flapstab::ns {

// A sponge layer along the box faces (an absorbing layer: e.g. Colonius 2004, Annu Rev Fluid Mech 36:315). Within
// width[f] of face f the momentum equation carries the relaxation -sigma(x) (u - u_far) with
//   sigma = rate xi^2,  xi = 1 - (distance from face f) / width[f]  (1 at the face, 0 at the layer's inner edge),
// the largest over the faces where layers overlap, and u_far = velocity - frame_rate x r, the far field the velocity
// faces prescribe (SolverOptions::frame_rate). It is integrated implicitly with each stage's alpha dt, so any rate is
// stable; a flow equal to u_far is left exactly as it is. It damps what the flow carries towards the faces (a wake)
// before it reaches them.
struct Sponge {
  std::array<double, 6> width{};  // m, indexed by face(axis, side); 0: no layer at that face
  double rate = 0;                 // sigma at the face (1/s)
  Vec3 velocity = Vec3::Zero();    // the far-field stream (m/s, the grid's frame)
  bool active() const {
    if (!(rate > 0)) return false;
    for (double w : width)
      if (w > 0) return true;
    return false;
  }
};

struct SolverOptions {
  double nu = 0;           // kinematic viscosity (m^2/s, or 1/Re in scaled units)
  double cfl = 1.0;        // adaptive step: dt max(sum_a |u_a|/dx_a) <= cfl (RK3 with central fluxes: stable to sqrt 3)
  double diffusion = 0.5;  // adaptive step: dt nu sum_a 1/dx_a^2 <= diffusion (RK3: stable to 0.63)
  double dt = 0;           // > 0: fixed step (e.g. a whole number of steps per wingbeat) instead of the adaptive one
  double dt_max = std::numeric_limits<double>::infinity();  // cap of the adaptive step
  PoissonOptions poisson{.rtol = 1e-3};  // each projection removes all but 1e-3 of the predictor's divergence
  // Rate of the grid's frame (rad/s): non-zero for a grid fixed to a body turning steadily. The momentum equation
  // then carries the Coriolis acceleration -2 Omega x u; the centrifugal one, -Omega x (Omega x r) =
  // grad(|Omega x r|^2 / 2), is absorbed in the pressure, which becomes the reduced pressure
  // P = p - |Omega x r|^2 / 2 (kinematic). Boundary velocities are those seen in the rotating frame.
  Vec3 frame_rate = Vec3::Zero();
  // A frame whose rate changes in time (a body forced to oscillate, with the grid fixed to it): Omega(t) in place of
  // frame_rate. The momentum equation then also carries the Euler acceleration -dOmega/dt x r, a rotational field
  // that stays in the velocity; each stage adds its exact integral -(Omega(t_end) - Omega(t_start)) x r. The
  // Coriolis term takes Omega at the stage's start (explicit, like the convection), the far field and the sponge
  // target -Omega(t) x r at the stage's time. r is measured from the grid's origin, the frame's centre of rotation.
  std::function<Vec3(double t)> frame_rate_at{};
  Vec3 rate_at(double t) const { return frame_rate_at ? frame_rate_at(t) : frame_rate; }
  bool rotating() const { return bool(frame_rate_at) || frame_rate.squaredNorm() > 0; }
  Sponge sponge{};  // none unless a width and a rate are set
  // Keep the velocity after each step's first and second stage (Solver::stage_velocity; six more grid fields and two
  // copies per step): what force partitioning with the forced region as the body needs to take its terms in the form
  // of the step's last stage (docs/theory/force-partitioning.md).
  bool keep_stage_velocities = false;
};

// Per-cell state for an immersed boundary (all cells fluid until a body is immersed).
enum class CellFlag : std::uint8_t { fluid = 0, solid = 1, ghost = 2 };

// Where an immersed-boundary method plugs into each Runge-Kutta stage. Hooks run once per stage and sweep their
// own cells (no per-cell virtual calls).
class StageHooks {
 public:
  virtual ~StageHooks() = default;
  // ustar: predicted velocity with the box conditions at stage time t, before projection. Impose the body
  // velocity here (direct forcing / ghost-cell values at flagged cells).
  virtual void after_predictor(VectorField& ustar, double t, double alpha_dt) = 0;
  // u, p: projected velocity and updated pressure at stage time t with box ghosts filled; ghost-cell values for
  // the next stage's stencils and surface forces go here.
  virtual void after_projection(VectorField& u, Field& p, double t) = 0;
  // Whether after_projection reads u. Over ranks the hooks work on a window filled from the neighbours; a hook that
  // reads only p (the immersed boundary) saves the velocity window's refresh after the first two stages of a step
  // (the loads after the step read it, and it is refreshed after the last stage).
  virtual bool reads_projected_velocity() const { return true; }
};

class Solver {
 public:
  // grid, bc: the whole box. With a decomposition over several MPI ranks (decomposition.hpp) this rank solves its z
  // slab of it: grid(), velocity() and pressure() are the slab's (with ghost planes from the neighbours), the
  // diagnostics below are global, and every rank must call the same methods in the same order. Attached hooks (the
  // immersed boundary) work on a window: the slab widened by hook_halo planes at each cut (hook_grid(),
  // hook_velocity(), hook_pressure(), flags()), filled from the neighbours before each hook; the rank keeps its own
  // planes of what they change. A periodic z axis over ranks takes no hooks.
  Solver(Grid grid, Boundaries bc, SolverOptions opt, std::shared_ptr<const Decomposition> dec = {});

  // Samples u0 (and p0) at the faces (cell centres) at time t0, imposes the boundary conditions and projects
  // u onto the discretely divergence-free fields.
  void initialise(const std::function<Vec3(double x, double y, double z)>& u0, double t0 = 0,
                  const std::function<double(double x, double y, double z)>& p0 = {});

  // One time step (three RK3 stages, one projection each); returns the dt used.
  double step();

  double time() const { return t_; }
  double stable_dt() const;  // the step the next step() takes: adaptive, or the fixed one (checked for stability)
  double kinetic_energy() const { return dec_->sum(ns::kinetic_energy(grid_, u_)); }
  double max_divergence() const { return dec_->max(ns::max_divergence(grid_, u_)); }
  double cfl(double dt) const { return dt * dec_->max(max_rate(grid_, u_)); }
  double diffusion_number(double dt) const { return dt * viscous_rate_; }
  // Poisson statistics of the last step's projections (one per stage).
  const std::vector<PoissonStats>& poisson_stats() const { return stats_; }
  // Pressure solves since construction that stopped at max_cycles above their tolerance (the step goes on with the
  // divergence they leave), and the largest residual / tolerance among them (0 when none). A solve that ends no
  // better than it started throws instead: the pressure diverges.
  long unconverged_pressure_solves() const { return unconverged_; }
  double worst_pressure_residual() const { return worst_unconverged_; }
  std::size_t bytes() const;  // memory held by the solver

  const Grid& grid() const { return grid_; }
  const Slab& slab() const { return slab_; }  // this rank's planes of the whole grid's z axis
  // The grid and fields the hooks see (the slab's own on one rank; over ranks the window, whose fields exist while
  // hooks are attached), and the hook grid's planes this rank owns.
  static constexpr int hook_halo = 4;
  // Why hooks cannot run on these slabs of the whole z axis ("" when they can): over several ranks their window needs
  // a z axis that is not periodic and slabs of at least hook_halo + 1 planes.
  static std::string window_problem(const std::vector<Slab>& slabs, bool z_periodic);
  // Why `whole` cannot be split over `ranks` ranks, with hooks if `hooks` ("" when it can): the slabs are whole
  // blocks of the multigrid's alignment (Multigrid::z_unit), at least one per rank, and fit the hooks' window.
  static std::string split_problem(const Grid& whole, int ranks, bool hooks);
  const Grid& hook_grid() const { return windowed() ? window_grid_ : grid_; }
  const VectorField& hook_velocity() const { return windowed() ? wu_ : u_; }
  const Field& hook_pressure() const { return windowed() ? wp_ : p_; }
  int hook_first_plane() const { return windowed() && slab_.cut_lo ? hook_halo + 1 : 1; }
  int hook_last_plane() const { return hook_first_plane() + slab_.n - 1; }
  const Grid& whole_grid() const { return whole_; }
  const std::vector<Slab>& slabs() const { return slabs_; }  // every rank's
  const Decomposition& decomposition() const { return *dec_; }
  const Boundaries& boundaries() const { return bc_; }
  const SolverOptions& options() const { return opt_; }
  const VectorField& velocity() const { return u_; }
  const Field& pressure() const { return p_; }
  std::vector<CellFlag>& flags() { return windowed() ? wflags_ : flags_; }
  void attach(StageHooks* hooks);

  // Exact checkpoint/restart: a step depends on t, u, p and the previous step's pressure increments (the
  // Poisson initial guesses); restoring them reproduces the run bit for bit. restore() refills the box
  // ghosts and runs the attached hooks' after_projection at t, as the step that wrote them did.
  const VectorField& pressure_increments() const { return phi_; }
  // The sponge layer's force per unit mass on the velocity u, -sigma (u - u_far) (SolverOptions::sponge), at every
  // interior unknown; zero outside the layers and everywhere without a sponge. f must have the grid's shape.
  void sponge_force(const VectorField& u, VectorField& f) const;
  bool has_guess() const { return guess_; }
  // The last step's RK3 stages (SolverOptions::keep_stage_velocities): the velocity after stage k = 0, 1 (u_1, u_2,
  // ghosts filled at the stage's time). The last stage takes u_2 to the velocity() at time() as
  //   u = u_2 - dt (gamma N(u_2) + zeta N(u_1)) - alpha dt grad p,   N(v) = the convective minus the viscous term,
  // on every face the immersed boundary and the box leave alone, with p = pressure() and the coefficients
  // stage_coefficients(2). False before the first step and after restore().
  bool has_stage_velocities() const { return stages_kept_; }
  const VectorField& stage_velocity(int k) const;
  double last_dt() const { return dt_last_; }  // the last step's (0 before the first)
  static StageCoefficients stage_coefficients(int k);  // stage k = 0, 1, 2 of the low-storage RK3
  void restore(double t, const VectorField& u, const Field& p, const VectorField& phi, bool guess);

 private:
  void stage(double dt, const StageCoefficients& c, double t_stage);
  // The hooks' after_projection (on the window over ranks); read_after: the velocity is read before the next stage
  // (the loads after a step's last stage, or after a restore).
  void after_projection(double t, bool read_after);
  double time_step(double conv) const;
  void relax(VectorField& ustar, double alpha_dt, double t) const;  // the sponge layer's implicit relaxation
  // fn(flat index, sigma, u_far) at every unknown of component d in a layer; u_far with the frame rate `rate`
  template <class Fn>
  void sweep_sponge(int d, const Vec3& rate, Fn&& fn) const;

  void exchange(VectorField& u) const;  // the slab's ghost planes of every component
  bool windowed() const { return windowed_; }  // over ranks with a z axis that is not periodic
  void widen(const Field& f, Field& w) const { dec_->widen(f, slab_, hook_halo, w); }
  void keep_own(const Field& w, Field& f) const;  // the slab's planes of a window field back into f
  void refresh_window();  // the window's velocity and pressure from this rank's and its neighbours' planes

  std::shared_ptr<const Decomposition> dec_;
  Slab slab_;
  std::vector<Slab> slabs_;  // every rank's
  Grid whole_, grid_, window_grid_;
  Boundaries bc_;
  ScalarBCs pbc_;
  SolverOptions opt_;
  Poisson poisson_;
  VectorField u_, ustar_, rhs_u_;  // velocity, predicted velocity, previous stage's momentum right-hand side
  Field p_, div_;                   // pressure, Poisson right-hand side
  VectorField phi_;                 // pressure increment of each stage (next step's initial guess)
  std::array<VectorField, 2> stage_u_;  // with keep_stage_velocities: the velocity after stages 1 and 2
  bool stages_kept_ = false;
  double dt_last_ = 0;
  std::vector<CellFlag> flags_, wflags_;
  bool windowed_ = false;
  VectorField wu_;  // the hooks' window (hook_halo planes beyond each cut)
  Field wp_;
  // The sponge's sigma along each axis at the cell centres (c) and at the faces (f); sigma at a point is the largest
  // of its three axes' values. Empty without a sponge.
  std::array<std::vector<double>, 3> sponge_c_, sponge_f_;
  std::array<std::vector<int>, 3> sponge_band_;  // per component: the x indices inside an x layer
  StageHooks* hooks_ = nullptr;
  std::vector<PoissonStats> stats_;
  double t_ = 0;
  double rate_ = 0;  // velocity-gradient scale of the current step (1/s), for the Poisson round-off floor
  double viscous_rate_ = 0;  // max over the whole grid of nu sum_a 1 / dx_a^2
  int stage_ = 0;
  bool guess_ = false;  // phi_ holds the previous step's increments
  long unconverged_ = 0, solves_ = 0;
  double worst_unconverged_ = 0;
};

}  // namespace flapstab::ns
