// Force partitioning of the loads on immersed parts (partition.hpp, docs/theory/force-partitioning.md).
#include "cfd/fpm/partition.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include "cfd/navier_stokes/diagnostics.hpp"
#include "cfd/navier_stokes/operators.hpp"

namespace flapstab::fpm {

namespace {

// The normal velocity u_d on every face of the domain's boundary planes (d non-periodic; plane 2 d + side), each
// plane indexed by plane_index.
std::size_t plane_index(const Shape& s, int d, int i, int j, int k) {
  const int I[3] = {i, j, k};
  const int e = (d + 1) % 3, f = (d + 2) % 3;
  return std::size_t(I[f] - 1) * std::size_t(s.n(e)) + std::size_t(I[e] - 1);
}

std::array<std::vector<double>, 6> boundary_normal_velocities(const Grid& g, const ns::VectorField& u) {
  std::array<std::vector<double>, 6> planes;
  const Shape s = g.shape();
  for (int d = 0; d < 3; ++d) {
    if (g.axis[std::size_t(d)].periodic) continue;
    const int e = (d + 1) % 3, f = (d + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      auto& plane = planes[std::size_t(2 * d + side)];
      plane.assign(std::size_t(s.n(e)) * std::size_t(s.n(f)), 0.0);
      for (int b = 1; b <= s.n(f); ++b)
        for (int a = 1; a <= s.n(e); ++a) {
          int F[3];
          F[d] = side == 0 ? 1 : s.n(d) + 1;
          F[e] = a;
          F[f] = b;
          plane[std::size_t(b - 1) * std::size_t(s.n(e)) + std::size_t(a - 1)] = u[d](F[0], F[1], F[2]);
        }
    }
  }
  return planes;
}

constexpr int kPower = 6;

// The Neumann datum of component k integrated over a surface piece: int n_k dS, or int ((x - x0) x n)_(k-3) dS; for the
// power potential (k = 6) int v . n dS with the rigid velocity v(x) = v_c + omega x (x - c) of the piece's part.
double datum(const FluidGeometry::Cut& c, int k, const Vec3& x0, const std::vector<PartState>& states) {
  if (k < 3) return c.area[k];
  if (k < 6) return (c.moment - x0.cross(c.area))[k - 3];
  const ns::RigidVelocity& v = states[std::size_t(c.part)].velocity;
  return v.velocity.dot(c.area) + v.omega.dot(c.moment - v.centre.cross(c.area));
}

}  // namespace

ForcePartition::ForcePartition(const Grid& g, FpmOptions options) : grid_(&g), opt_(std::move(options)) {
  for (int k : opt_.components)
    if (k < 0 || k > 5) throw std::invalid_argument("force partitioning: component " + std::to_string(k) + " is not 0..5");
}

const FluidGeometry& ForcePartition::geometry() const {
  if (!geometry_) throw std::logic_error("force partitioning: no potentials yet (call update first)");
  return *geometry_;
}

const Field& ForcePartition::potential(int part, int component) const {
  const Field& f = phi_.at(std::size_t(part)).at(std::size_t(component));
  if (!(f.shape() == grid_->shape()))
    throw std::invalid_argument("force partitioning: no potential of component " + std::to_string(component) +
                                " (not among the options' components, or no update yet)");
  return f;
}

const std::vector<PotentialReport>& ForcePartition::update(const ns::ImmersedBoundary& ib,
                                                           const std::vector<PartState>& states) {
  if (states.size() != ib.parts())
    throw std::invalid_argument("force partitioning: " + std::to_string(states.size()) + " part states for " +
                                std::to_string(ib.parts()) + " parts");
  const LevelFunction level = [&](int part, const Vec3& x, double h) {
    return ib.solid_level_set(part, states[std::size_t(part)], x, h);
  };
  // faces are tested from the cells of the forcing's bands (a membrane's reaches past the cells it owns)
  const std::vector<int> band = ib.cell_owners(states, 1.0);
  return update(level, int(ib.parts()), ib.cell_owners(states), states, &band);
}

const std::vector<PotentialReport>& ForcePartition::update(const LevelFunction& level, int parts,
                                                           const std::vector<int>& owners,
                                                           const std::vector<PartState>& states,
                                                           const std::vector<int>* near) {
  if (opt_.power && states.size() != std::size_t(parts))
    throw std::invalid_argument("force partitioning: the power potential needs the states of the " +
                                std::to_string(parts) + " parts");
  const Grid& g = *grid_;
  geometry_ =
      std::make_unique<FluidGeometry>(fluid_geometry(g, parts, level, owners, opt_.face_samples, opt_.body, near));
  const FluidGeometry& o = *geometry_;
  {
    auto next = std::make_unique<NeumannLaplacian>(g, o);
    if (laplace_) next->take_workspace(*laplace_);
    laplace_ = std::move(next);
  }
  const NeumannLaplacian& L = *laplace_;
  const Shape s = g.shape();
  // the domain's faces next to active (fluid) cells
  outer_.clear();
  outer_area_ = 0;
  for (int d = 0; d < 3; ++d) {
    if (g.axis[std::size_t(d)].periodic) continue;
    const int e = (d + 1) % 3, f = (d + 2) % 3;
    for (int side = 0; side < 2; ++side)
      for (int b = 1; b <= s.n(f); ++b)
        for (int a = 1; a <= s.n(e); ++a) {
          int I[3];
          I[d] = side == 0 ? 1 : s.n(d);
          I[e] = a;
          I[f] = b;
          if (!L.active(I[0], I[1], I[2])) continue;
          const double area = g.axis[std::size_t(e)].dc[std::size_t(a)] * g.axis[std::size_t(f)].dc[std::size_t(b)];
          outer_.push_back({s(I[0], I[1], I[2]), d, side, I[0], I[1], I[2], area});
          outer_area_ += area;
        }
  }
  const auto& outer = outer_;
  const double outer_area = outer_area_;
  std::vector<int> potentials = opt_.components;
  if (opt_.power) potentials.push_back(kPower);
  // only the potentials asked for hold storage (7 per part would be 21 fields of the grid for an insect)
  if (phi_.size() != std::size_t(parts)) phi_.assign(std::size_t(parts), {});
  for (auto& a : phi_)
    for (int k : potentials)
      if (!(a[std::size_t(k)].shape() == s)) a[std::size_t(k)] = Field(s);
  reports_.clear();
  // Every right-hand side first: the potentials of one sample share the operator and are solved together.
  std::vector<Field> rhs;
  std::vector<Field*> xs;
  std::vector<const Field*> bs;
  rhs.reserve(std::size_t(parts) * potentials.size());
  for (int p = 0; p < parts; ++p)
    for (int k : potentials) {
      Field& b = rhs.emplace_back(s);
      double total = 0, magnitude = 0;
      for (const auto& c : o.cuts) {
        if (c.part != p) continue;
        const double flux = -datum(c, k, opt_.moment_point, states);
        b[c.cell] += flux;
        total += flux;
        magnitude += std::abs(flux);
      }
      // Where part p's wetted staircase is not closed (it touches another part), the fluxes do not sum to zero;
      // the remainder leaves through the domain's faces, spread by area (a far-field source).
      if (outer_area > 0)
        for (const auto& f : outer) b[f.cell] -= total * f.area / outer_area;
      PotentialReport r;
      r.part = p;
      r.component = k;
      r.imbalance = magnitude > 0 ? std::abs(total) / magnitude : 0.0;
      r.outflow = outer_area > 0 ? total : 0.0;
      r.pocket_cells = o.pocket_cells;
      reports_.push_back(r);
      xs.push_back(&phi_[std::size_t(p)][std::size_t(k)]);
      bs.push_back(&b);
    }
  // Start from the potentials extrapolated linearly from the last two samples (2 phi_n - phi_(n-1)): the parts move
  // smoothly between samples. On the hawkmoth at 40 samples per wingbeat (bench/bench_fpm.cpp, 2 threads) the mean
  // iterations per solve are 3.83 against 4.0 from the previous potential, the cost ratio 1.36 against 1.41 (with
  // the earlier two-sweep smoother 7.48 against 8.46). The first two updates start from the previous potential
  // (zero at the first).
  if (phi_prev_.size() != phi_.size()) phi_prev_.assign(phi_.size(), {});
  for (int p = 0; p < parts; ++p)
    for (int k : potentials) {
      Field& cur = phi_[std::size_t(p)][std::size_t(k)];
      Field& prev = phi_prev_[std::size_t(p)][std::size_t(k)];
      if (updates_ < 2 || !(prev.shape() == s)) {
        prev = cur;
        continue;
      }
      double* c = cur.data();
      double* q = prev.data();
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (std::ptrdiff_t n = 0; n < std::ptrdiff_t(s.size()); ++n) {
        const double now = c[n];
        c[n] = 2 * now - q[n];
        q[n] = now;
      }
    }
  ++updates_;
  const std::vector<LaplaceStats> stats = L.solve(xs, bs, opt_.rtol, opt_.max_iterations);
  for (std::size_t m = 0; m < xs.size(); ++m) {
    PotentialReport& r = reports_[m];
    Field& phi = *xs[m];
    r.stats = stats[m];
    if (!r.stats.converged) {  // the previous potential was a poor start (or not finite): once more from zero
      phi.fill(0);
      const int before = r.stats.iterations;
      r.stats = L.solve(phi, *bs[m], opt_.rtol, 2 * opt_.max_iterations);
      r.stats.iterations += before;
    }
    // phi -> 0 far away: its area-weighted mean over the cells on the domain's faces is zero.
    double mean = 0;
    if (outer_area > 0) {
      for (const auto& f : outer) mean += phi[f.cell] * f.area / outer_area;
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (int kk = 1; kk <= s.nz; ++kk)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) {
            const std::ptrdiff_t n = s(i, j, kk);
            if (o.active(n)) phi[n] -= mean;
          }
    }
    fill_periodic_ghosts(g, phi);
  }
  return reports_;
}

std::vector<PartPartition> ForcePartition::partition(const ns::Solver& solver, const std::vector<PartState>& states,
                                                     double rho) {
  if (!geometry_) throw std::logic_error("force partitioning: partition() before update()");
  if (solver.options().rotating())
    throw std::invalid_argument("force partitioning needs an inertial grid frame (this run's grid turns with the body)");
  const Grid& g = *grid_;
  const FluidGeometry& o = *geometry_;
  const Shape s = g.shape();
  if (!(solver.grid().shape() == s)) throw std::invalid_argument("force partitioning: the solver's grid differs");
  const int parts = o.parts;
  if (states.size() != std::size_t(parts)) throw std::invalid_argument("force partitioning: part states do not match");
  rho_ = rho;
  const double mu = rho * solver.options().nu;
  const ns::VectorField& u = solver.velocity();
  const Field& p = solver.pressure();
  const auto& outer = outer_;
  const Vec3& x0 = opt_.moment_point;

  const bool widened = opt_.body == FpmBody::forced_region;
  // Q at the cell centres (the solver's velocity, forced values inside the parts included); with the forced region
  // as the body, the solver's own discrete Q, below
  if (!widened) q_ = ns::centre_fields(g, u).q;
  auto flat = [&](int i, int j, int k) { return (std::size_t(k - 1) * s.ny + std::size_t(j - 1)) * s.nx + std::size_t(i - 1); };

  // With the forced region as the body every term is taken in the form of the step's last Runge-Kutta stage, which
  // on each open face balances the pressure at the step's end exactly (ns::Solver::stage_velocity): the rate
  // (u - u_2) / (alpha dt) and the convective and viscous terms of wg u_2 + wz u_1 (wg = gamma / alpha, wz = zeta /
  // alpha of that stage; they sum to 1). Before the first step (no stages) u_2 = u_1 = u and no rate.
  if (widened && !solver.options().keep_stage_velocities)
    throw std::invalid_argument("force partitioning with the forced region as the body needs the solver's stage "
                                "velocities (ns::SolverOptions::keep_stage_velocities)");
  const bool staged = widened && solver.has_stage_velocities();
  const ns::VectorField& u2 = staged ? solver.stage_velocity(1) : u;
  const ns::VectorField& u1 = staged ? solver.stage_velocity(0) : u;
  const ns::StageCoefficients last = ns::Solver::stage_coefficients(2);
  const double wg = staged ? last.gamma / last.alpha() : 1.0, wz = staged ? last.zeta / last.alpha() : 0.0;
  const double adt = last.alpha() * solver.last_dt();

  // Du/Dt . n on the domain's faces next to fluid cells (n out of the domain)
  const double t = solver.time();
  std::array<std::vector<double>, 6> un_now = boundary_normal_velocities(g, u);
  auto boundary_face = [&](const DomainFace& f) {  // the face's index along its axis d
    int F[3] = {f.i, f.j, f.k};
    F[f.d] = f.side == 0 ? 1 : g.axis[std::size_t(f.d)].n + 1;
    return std::array<int, 3>{F[0], F[1], F[2]};
  };
  // u . grad u . n of the velocity v: u_d du_d/dx_d one-sided into the domain, u_a du_d/dx_a central along the face
  auto outer_convection = [&](const ns::VectorField& v) {
    std::vector<double> out(outer.size());
    std::size_t m = 0;
    for (const auto& f : outer) {
      const int d = f.d, e = (d + 1) % 3, h = (d + 2) % 3;
      const ns::Axis& ad = g.axis[std::size_t(d)];
      const std::array<int, 3> F = boundary_face(f);
      const Field& ud = v[d];
      const double un = ud(F[0], F[1], F[2]);
      int G[3] = {F[0], F[1], F[2]};
      G[d] += f.side == 0 ? 1 : -1;
      const double dudd = (f.side == 0 ? ud(G[0], G[1], G[2]) - un : un - ud(G[0], G[1], G[2])) /
                          ad.dc[std::size_t(f.side == 0 ? 1 : ad.n)];
      double conv = un * dudd;
      for (int a : {e, h}) {
        const ns::Axis& aa = g.axis[std::size_t(a)];
        // u_a at the boundary face: the four a-faces of the boundary cell and of its ghost image
        int C[3] = {f.i, f.j, f.k}, Gh[3] = {f.i, f.j, f.k};
        Gh[d] += f.side == 0 ? -1 : 1;
        int C1[3] = {C[0], C[1], C[2]}, G1[3] = {Gh[0], Gh[1], Gh[2]};
        ++C1[a];
        ++G1[a];
        const double ua = 0.25 * (v[a](C[0], C[1], C[2]) + v[a](C1[0], C1[1], C1[2]) + v[a](Gh[0], Gh[1], Gh[2]) +
                                  v[a](G1[0], G1[1], G1[2]));
        int P[3] = {F[0], F[1], F[2]}, M[3] = {F[0], F[1], F[2]};
        ++P[a];
        --M[a];
        const double dx = aa.xc[std::size_t(P[a])] - aa.xc[std::size_t(M[a])];
        conv += ua * (ud(P[0], P[1], P[2]) - ud(M[0], M[1], M[2])) / dx;
      }
      out[m++] = conv * (f.side == 0 ? -1.0 : 1.0);
    }
    return out;
  };
  std::vector<double> conv_n = outer_convection(u2);  // its convective part u . grad u . n
  if (wz != 0) {
    const std::vector<double> first = outer_convection(u1);
    for (std::size_t m = 0; m < outer.size(); ++m) conv_n[m] = wg * conv_n[m] + wz * first[m];
  }
  std::vector<double> dudt_n(outer.size(), 0.0);
  for (std::size_t m = 0; m < outer.size(); ++m) {
    const DomainFace& f = outer[m];
    const std::array<int, 3> F = boundary_face(f);
    const double un = u[f.d](F[0], F[1], F[2]);
    // d u_n / dt: over the last stage, or from the previous record of the same face (none at the first call)
    double rate = 0;
    if (staged) {
      rate = (un - u2[f.d](F[0], F[1], F[2])) / adt;
    } else {
      const std::size_t plane = std::size_t(2 * f.d + f.side), idx = plane_index(s, f.d, f.i, f.j, f.k);
      const auto& prev = un_prev_[plane];
      if (have_prev_ && t > t_prev_ && idx < prev.size()) rate = (un - prev[idx]) / (t - t_prev_);
    }
    dudt_n[m] = rate * (f.side == 0 ? -1.0 : 1.0) + conv_n[m];
  }

  // mu lap u . grad phi per open face (both cells fluid) without grad phi: the MAC Laplacian of u_d at the face
  // times its open area beta A (the same for every potential, so computed once). With a sponge layer also its force
  // per unit mass f = -sigma (u - u_far) (Solver::sponge_force) times beta A, weighted with grad phi the same way:
  // rho int f . grad phi dV, a part of the outer term (the far field's treatment, its faces and its layer). In the
  // last stage's form the layer relaxes the predicted velocity, u + alpha dt grad(phi_3) with phi_3 that stage's
  // pressure increment, not u.
  ns::VectorField lap_area(s);
  const bool sponge = solver.options().sponge.active();
  ns::VectorField sponge_area;  // f beta A per open face; zero elsewhere
  if (sponge) {
    sponge_area = ns::VectorField(s);
    if (staged) {  // the solver's projection run backwards: u* = u + alpha dt grad(phi_3)
      ns::VectorField predicted(s);
      Field scratch(s);  // the projection's pressure update, not needed here
      ns::project(g, u, solver.pressure_increments()[2], predicted, scratch, -adt);
      solver.sponge_force(predicted, sponge_area);
    } else {
      solver.sponge_force(u, sponge_area);
    }
  }
  for (int d = 0; d < 3; ++d) {
    const ns::Axis& ad = g.axis[std::size_t(d)];
    const int e = (d + 1) % 3, h = (d + 2) % 3;
    const Field& ud = u[d];
    const std::vector<char>& forced_d = o.forced[std::size_t(d)];
    Field& w = lap_area[d];  // zero where no open face or a forced one
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int kk = 1; kk <= s.nz; ++kk)
      for (int j = 1; j <= s.ny; ++j)
        for (int ii = 1; ii <= s.nx; ++ii) {
          const int I[3] = {ii, j, kk};
          if (!ad.periodic && I[d] == 1) {
            if (sponge) sponge_area[d](ii, j, kk) = 0;
            continue;
          }
          const double beta = o.aperture[std::size_t(d)](ii, j, kk);
          const double area = g.axis[std::size_t(e)].dc[std::size_t(I[e])] * g.axis[std::size_t(h)].dc[std::size_t(I[h])];
          if (sponge) sponge_area[d](ii, j, kk) *= beta > 0 ? beta * area : 0.0;
          // Faces the immersed boundary forces are left out: their MAC Laplacian spans the kink between the band's
          // reconstructed profile and the rigid velocity inside the part, about mu du/dn per unit area, which does not
          // vanish with the grid; the momentum equation it stands for does not hold there (direct forcing replaces it).
          if (beta <= 0 || forced_d[std::size_t(s(ii, j, kk))]) continue;
          double lap = face_laplacian(g, staged ? u2[d] : ud, d, ii, j, kk);
          if (wz != 0) lap = wg * lap + wz * face_laplacian(g, u1[d], d, ii, j, kk);
          w(ii, j, kk) = lap * beta * area;
        }
  }

  // The open faces the immersed boundary forces, with a_f (p_c - p_nb): the pressure's share there is the sum of
  // these times (phi_c - phi_nb) (the discrete Green identity of the direct pressure force)
  struct ForcedFace {
    std::ptrdiff_t n, stride;
    double weight;
  };
  std::vector<ForcedFace> forced_faces;
  for (const FluidGeometry::Face& f : o.forced_open) {
    const int e = (f.d + 1) % 3, h = (f.d + 2) % 3;
    const std::ptrdiff_t n = s(f.I[0], f.I[1], f.I[2]), stride = f.d == 0 ? 1 : f.d == 1 ? s.sy : s.sz;
    const double area = g.axis[std::size_t(e)].dc[std::size_t(f.I[e])] * g.axis[std::size_t(h)].dc[std::size_t(f.I[h])];
    const double a_f = o.aperture[std::size_t(f.d)][n] * area * g.axis[std::size_t(f.d)].idf[std::size_t(f.I[f.d])];
    forced_faces.push_back({n, stride, a_f * (p[n] - p[n - stride])});
  }

  // With the forced region as the body the convective terms are taken in the solver's own discrete form, so that they
  // sum by parts exactly to its momentum equation's convective term on the open faces (docs/theory/
  // force-partitioning.md, "The forced region as the body"): c = sum_e d/dx_e (u_e u_d) at every face of an active
  // cell (ns::convective_acceleration; on the domain's faces the outer term's u . grad u . n). The kinematic term
  // takes du_d/dt + c_d on each closed face beside an active cell (the fluid there slides along the body, so not the
  // parts' rigid accelerations), times the face's area (the same for every potential); the vortex-induced term takes
  // each active cell's net outflow of c, the discrete int div(u . grad u) dV = -2 int Q dV, as its Q.
  struct WallFace {
    std::ptrdiff_t up, low;  // the active cells above and below the face along d (-1: none)
    double weight;           // A (du_d/dt + c_d)
  };
  std::vector<WallFace> wall_faces;
  if (widened) {
    auto face_area = [&](int d, const int* I) {
      const int e = (d + 1) % 3, h = (d + 2) % 3;
      return g.axis[std::size_t(e)].dc[std::size_t(I[e])] * g.axis[std::size_t(h)].dc[std::size_t(I[h])];
    };
    // q_ first holds each active cell's net outflow of c through its six faces (the domain's from the outer term);
    // cf holds c_d at the lower face of every cell, one direction at a time (each face evaluated once)
    q_.assign(s.cells(), 0.0);
    std::vector<double> cf(s.cells());
    for (int d = 0; d < 3; ++d) {
      const ns::Axis& ad = g.axis[std::size_t(d)];
      const std::ptrdiff_t fs = d == 0 ? 1 : d == 1 ? std::ptrdiff_t(s.nx) : std::ptrdiff_t(s.nx) * s.ny;
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (int kk = 1; kk <= s.nz; ++kk)
        for (int j = 1; j <= s.ny; ++j)
          for (int ii = 1; ii <= s.nx; ++ii) {
            const int I[3] = {ii, j, kk};
            double c = 0;
            if (I[d] > 1 || ad.periodic) {
              c = ns::convective_acceleration(g, u2, d, ii, j, kk);
              if (wz != 0) c = wg * c + wz * ns::convective_acceleration(g, u1, d, ii, j, kk);
            }
            cf[flat(ii, j, kk)] = c;
          }
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (int kk = 1; kk <= s.nz; ++kk)
        for (int j = 1; j <= s.ny; ++j)
          for (int ii = 1; ii <= s.nx; ++ii) {
            if (!o.active(s(ii, j, kk))) continue;
            const int I[3] = {ii, j, kk};
            const std::ptrdiff_t m = std::ptrdiff_t(flat(ii, j, kk));
            // the upper face: the next cell's lower face; face n + 1 of a periodic axis is face 1
            double net = I[d] < ad.n    ? cf[std::size_t(m + fs)]
                         : ad.periodic ? cf[std::size_t(m - (ad.n - 1) * fs)]
                                       : 0.0;
            if (I[d] > 1 || ad.periodic) net -= cf[std::size_t(m)];
            q_[std::size_t(m)] += face_area(d, I) * net;
          }
      // the closed faces along d beside an active cell
      for (int kk = 1; kk <= s.nz; ++kk)
        for (int j = 1; j <= s.ny; ++j)
          for (int ii = 1; ii <= s.nx; ++ii) {
            const int I[3] = {ii, j, kk};
            if (I[d] == 1 && !ad.periodic) continue;  // the domain's faces: the outer term
            const std::ptrdiff_t n = s(ii, j, kk);
            if (o.aperture[std::size_t(d)][n] > 0) continue;  // open: the momentum equation's face
            // the cell below; across a periodic seam (face 1) the last cell along d
            int Lo[3] = {ii, j, kk};
            Lo[d] = I[d] == 1 ? ad.n : I[d] - 1;
            const std::ptrdiff_t low_n = s(Lo[0], Lo[1], Lo[2]);
            const bool up = o.active(n), low = o.active(low_n);
            if (!up && !low) continue;
            double acc = cf[flat(ii, j, kk)];
            if (staged) acc += (u[d](ii, j, kk) - u2[d](ii, j, kk)) / adt;
            wall_faces.push_back({up ? n : -1, low ? low_n : -1, face_area(d, I) * acc});
          }
    }
    for (std::size_t m = 0; m < outer.size(); ++m)
      q_[flat(outer[m].i, outer[m].j, outer[m].k)] += outer[m].area * conv_n[m];
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int kk = 1; kk <= s.nz; ++kk)
      for (int j = 1; j <= s.ny; ++j)
        for (int ii = 1; ii <= s.nx; ++ii) {
          const double vf = o.volume_fraction(ii, j, kk);
          double& q = q_[flat(ii, j, kk)];
          q = vf > 0 ? -0.5 * q / (g.volume(ii, j, kk) * vf) : 0.0;  // Q = -(1/2) div(u . grad u)
        }
  }

  // The widened body's kinematic term takes the rate in its volume form, -rho sum_open A_f (du_d/dt)_f
  // (phi_c - phi_nb), which summed by parts is the closed faces' share above plus rho sum_cells phi_c V_c
  // div(du/dt)_c: the divergence the projections leave over the last stage (zero if they were exact). Its weight of
  // phi per active cell.
  std::vector<double> rate_weight;
  if (staged) {
    rate_weight.assign(s.cells(), 0.0);
    Field now(s), before(s);
    ns::divergence(g, u, now, 1.0);
    ns::divergence(g, u2, before, 1.0);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int kk = 1; kk <= s.nz; ++kk)
      for (int j = 1; j <= s.ny; ++j)
        for (int ii = 1; ii <= s.nx; ++ii)
          if (o.active(s(ii, j, kk)))
            rate_weight[flat(ii, j, kk)] = g.volume(ii, j, kk) * (now(ii, j, kk) - before(ii, j, kk)) / adt;
  }

  // Q times the cell's fluid volume, the vortex-induced term's weight of phi
  std::vector<double> vortex_weight(s.cells());
#pragma omp parallel for schedule(static) if (ns::threaded(s))
  for (int kk = 1; kk <= s.nz; ++kk)
    for (int j = 1; j <= s.ny; ++j)
      for (int ii = 1; ii <= s.nx; ++ii) {
        const std::size_t n = flat(ii, j, kk);
        vortex_weight[n] = q_[n] * g.volume(ii, j, kk) * o.volume_fraction(ii, j, kk);
      }

  // the area-weighted mean pressure on the domain's faces (of the cells next to them)
  double outer_pressure = 0;
  if (outer_area_ > 0)
    for (const auto& f : outer) outer_pressure += p[f.cell] * f.area / outer_area_;

  // The terms of one potential of part i (datum k): rho-scaled as in the partition's formula, the regions' share of the
  // vortex-induced part (region_count_ entries; none without regions).
  struct Terms {
    double kinematic = 0, centripetal = 0, vortex = 0, viscous = 0, outer = 0, pressure = 0, pressure_forced = 0;
    std::vector<double> regions;
  };
  auto terms = [&](int i, int k) {
    const Field& phi = phi_[std::size_t(i)][std::size_t(k)];
    Terms T;
    double kin = 0, car = 0, direct = 0;
    for (const auto& c : o.cuts) {
      const PartState& st = states[std::size_t(c.part)];
      const Vec3 r = c.centroid - st.velocity.centre;
      const Vec3 centripetal = st.velocity.omega.cross(st.velocity.omega.cross(r));
      const Vec3 a = st.acceleration + st.angular_acceleration.cross(r) + centripetal;
      kin += phi[c.cell] * a.dot(c.area);
      car += phi[c.cell] * centripetal.dot(c.area);
      if (c.part == i) direct -= p[c.cell] * datum(c, k, x0, states);
    }
    // -2 rho int Q phi dV (by region) and mu int lap u . grad phi over the open faces (grad phi df beta A =
    // (phi_h - phi_l) beta A), in one pass over the cells
    const int nr = std::max(region_count_, 1);
    std::vector<double> by_region(std::size_t(nr), 0.0);
    double* acc = by_region.data();
    double visc = 0, layer = 0, rate = 0;  // layer: int f . grad phi dV of the sponge layer
    const int* label = region_count_ > 0 ? region_labels_.data() : nullptr;
    const double *w0 = lap_area[0].data(), *w1 = lap_area[1].data(), *w2 = lap_area[2].data();
    const double* f0 = sponge ? sponge_area[0].data() : nullptr;
    const double* f1 = sponge ? sponge_area[1].data() : nullptr;
    const double* f2 = sponge ? sponge_area[2].data() : nullptr;
    const std::ptrdiff_t sy = s.sy, sz = s.sz;
    const double* rw = rate_weight.empty() ? nullptr : rate_weight.data();
#pragma omp parallel for schedule(static) reduction(+ : acc[:nr], visc, layer, rate) if (ns::threaded(s))
    for (int kk = 1; kk <= s.nz; ++kk)
      for (int j = 1; j <= s.ny; ++j) {
        const std::size_t m0 = flat(1, j, kk);
        const std::ptrdiff_t n0 = s(1, j, kk);
        double line = 0, line_layer = 0, line_rate = 0;
        for (int ii = 0; ii < s.nx; ++ii) {
          const std::ptrdiff_t n = n0 + ii;
          const double f = phi[n], dx = f - phi[n - 1], dy = f - phi[n - sy], dz = f - phi[n - sz];
          line += w0[n] * dx + w1[n] * dy + w2[n] * dz;
          if (f0) line_layer += f0[n] * dx + f1[n] * dy + f2[n] * dz;
          if (rw) line_rate += rw[m0 + std::size_t(ii)] * f;
          acc[label ? label[m0 + std::size_t(ii)] : 0] += vortex_weight[m0 + std::size_t(ii)] * f;
        }
        visc += line;
        layer += line_layer;
        rate += line_rate;
      }
    double vortex = 0;
    for (double v : by_region) vortex += v;
    if (region_count_ > 0)
      for (double v : by_region) T.regions.push_back(-2 * rho * v);
    double outer_term = 0;
    for (std::size_t m = 0; m < outer.size(); ++m) outer_term += phi[outer[m].cell] * dudt_n[m] * outer[m].area;
    // Where part i's wetted surface is not closed its potential's flux leaves through the domain's faces (update()),
    // and the Green identity gains the pressure there: -oint_domain p dphi/dn dS = the flux times the area-weighted
    // mean pressure on the domain's faces, a part of the outer term.
    double far_pressure = 0;
    for (const PotentialReport& r : reports_)
      if (r.part == i && r.component == k && r.outflow != 0) far_pressure = r.outflow * outer_pressure;
    T.kinematic = rho * kin;
    T.centripetal = rho * car;
    T.vortex = -2 * rho * vortex;
    T.viscous = mu * visc;
    T.outer = -rho * outer_term + rho * layer + rho * far_pressure;
    T.pressure = rho * direct;
    double band = 0;
    for (const ForcedFace& f : forced_faces) band += f.weight * (phi[f.n] - phi[f.n - f.stride]);
    T.pressure_forced = rho * band;
    if (widened) {  // the fluid's acceleration on the widened body's faces
      double wall = 0;
      for (const WallFace& f : wall_faces)
        wall += f.weight * ((f.up >= 0 ? phi[f.up] : 0.0) - (f.low >= 0 ? phi[f.low] : 0.0));
      T.kinematic = rho * (wall + rate);
    }
    return T;
  };

  std::vector<PartPartition> out(static_cast<std::size_t>(parts));
  for (int i = 0; i < parts; ++i) {
    PartPartition& P = out[std::size_t(i)];
    if (region_count_ > 0) P.vortex_regions.assign(std::size_t(region_count_), Vec6::Zero());
    for (int k : opt_.components) {
      const Terms T = terms(i, k);
      P.kinematic[k] = T.kinematic;
      P.centripetal[k] = T.centripetal;
      P.vortex[k] = T.vortex;
      P.viscous[k] = T.viscous;
      P.outer[k] = T.outer;
      P.pressure[k] = T.pressure;
      P.pressure_forced[k] = T.pressure_forced;
      for (std::size_t r = 0; r < T.regions.size(); ++r) P.vortex_regions[r][k] = T.regions[r];
    }
    if (opt_.power) {
      // the power potential's partition is the pressure's rate of work on the part by mechanism; the part's on the
      // fluid is its negative
      const Terms T = terms(i, kPower);
      P.power_kinematic = -T.kinematic;
      P.power_centripetal = -T.centripetal;
      P.power_vortex = -T.vortex;
      P.power_viscous = -T.viscous;
      P.power_outer = -T.outer;
      P.power_pressure = -T.pressure;
      P.power_pressure_forced = -T.pressure_forced;
      for (double v : T.regions) P.power_vortex_regions.push_back(-v);
    } else {
      const PartState& st = states[std::size_t(i)];
      const Vec3 v0 = st.velocity.at(x0), w = st.velocity.omega;
      auto power = [&](const Vec6& f) { return -(f.head<3>().dot(v0) + f.tail<3>().dot(w)); };
      P.power_kinematic = power(P.kinematic);
      P.power_vortex = power(P.vortex);
      P.power_viscous = power(P.viscous);
      P.power_outer = power(P.outer);
      P.power_pressure = power(P.pressure);
      P.power_pressure_forced = power(P.pressure_forced);
    }
  }
  un_prev_ = std::move(un_now);
  t_prev_ = t;
  have_prev_ = true;
  return out;
}

void ForcePartition::set_regions(std::vector<int> labels, int count) {
  if (!labels.empty()) {
    if (labels.size() != grid_->shape().cells())
      throw std::invalid_argument("force partitioning: region labels for " + std::to_string(labels.size()) +
                                  " cells, the grid has " + std::to_string(grid_->shape().cells()));
    for (int l : labels)
      if (l < 0 || l >= count) throw std::invalid_argument("force partitioning: a region label outside 0 .. count - 1");
  }
  region_labels_ = std::move(labels);
  region_count_ = region_labels_.empty() ? 0 : count;
}

void ForcePartition::record_boundary(const ns::Solver& solver) {
  un_prev_ = boundary_normal_velocities(*grid_, solver.velocity());
  t_prev_ = solver.time();
  have_prev_ = true;
}

Eigen::Matrix<double, 6, 6> ForcePartition::added_mass(int i, int j, double rho) const {
  Eigen::Matrix<double, 6, 6> m = Eigen::Matrix<double, 6, 6>::Zero();
  for (const auto& c : geometry().cuts)
    if (c.part == j)
      for (int k : opt_.components)
        for (int l = 0; l < 6; ++l) m(k, l) -= rho * potential(i, k)[c.cell] * datum(c, l, opt_.moment_point, {});
  return m;
}

std::vector<double> ForcePartition::vortex_density(int part, int component) const {
  const Field& phi = potential(part, component);
  const Shape s = grid_->shape();
  std::vector<double> out(s.cells(), 0.0);
  if (q_.size() != s.cells()) return out;
  std::size_t m = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i, ++m)
        out[m] = -2 * rho_ * q_[m] * phi(i, j, k) * geometry_->volume_fraction(i, j, k);
  return out;
}

}  // namespace flapstab::fpm
