// MAC operators on the non-uniform grid (Harlow & Welch 1965 staggering; flux form of the momentum equation).
#include "cfd/navier_stokes/operators.hpp"
#include <algorithm>
#include <cmath>

namespace flapstab::ns {

namespace {

struct AxisView {
  const real *idc, *idf, *wlo, *whi;
  explicit AxisView(const Axis& a) : idc(a.idc.data()), idf(a.idf.data()), wlo(a.wlo.data()), whi(a.whi.data()) {}
};

// d/dx_e (u_e u_d) - nu d2u_d/dx_e2 at the u_d point n (face Id along d, cell Ie along e): the divergence of the
// convective and viscous fluxes through the two e-faces of u_d's control volume.
template <int d, int e>
inline real transport(const real* __restrict ud, const real* __restrict ue, std::ptrdiff_t n, std::ptrdiff_t sd,
                      std::ptrdiff_t se, const AxisView& Ad, const AxisView& Ae, int Id, int Ie, real nu) {
  if constexpr (d == e) {  // fluxes at the cell centres Id - 1 and Id, where u_d is the mean of its two faces
    const real hi = real(0.5) * (ud[n] + ud[n + sd]), lo = real(0.5) * (ud[n - sd] + ud[n]);
    const real visc = (ud[n + sd] - ud[n]) * Ad.idc[Id] - (ud[n] - ud[n - sd]) * Ad.idc[Id - 1];
    return (hi * hi - lo * lo - nu * visc) * Ad.idf[Id];
  } else {  // fluxes at the edges (face Id along d, faces Ie and Ie + 1 along e)
    const real ue_hi = Ad.wlo[Id] * ue[n + se - sd] + Ad.whi[Id] * ue[n + se];
    const real ue_lo = Ad.wlo[Id] * ue[n - sd] + Ad.whi[Id] * ue[n];
    const real ud_hi = Ae.wlo[Ie + 1] * ud[n] + Ae.whi[Ie + 1] * ud[n + se];
    const real ud_lo = Ae.wlo[Ie] * ud[n - se] + Ae.whi[Ie] * ud[n];
    const real visc = (ud[n + se] - ud[n]) * Ae.idf[Ie + 1] - (ud[n] - ud[n - se]) * Ae.idf[Ie];
    return (ue_hi * ud_hi - ue_lo * ud_lo - nu * visc) * Ae.idc[Ie];
  }
}

// Stride of direction d in the padded array; the unit stride of x must be a compile-time constant to vectorise.
template <int d>
inline std::ptrdiff_t stride(std::ptrdiff_t sy, std::ptrdiff_t sz) {
  if constexpr (d == 0) return 1;
  if constexpr (d == 1) return sy;
  return sz;
}

// The momentum right-hand side -r of component d at point n and the predicted value (see predict()).
template <int d>
inline void predict_point(const real* __restrict u0, const real* __restrict u1, const real* __restrict u2,
                          const real* __restrict pp, real* __restrict N, real* __restrict out, std::ptrdiff_t n,
                          std::ptrdiff_t sy, std::ptrdiff_t sz, AxisView X, AxisView Y, AxisView Z, int i, int j, int k,
                          real nu, real gdt, real zdt, real adt) {
  const real* ud = d == 0 ? u0 : d == 1 ? u1 : u2;
  const AxisView& Ad = d == 0 ? X : d == 1 ? Y : Z;
  const int Id = d == 0 ? i : d == 1 ? j : k;
  const std::ptrdiff_t sd = stride<d>(sy, sz);
  const real r = transport<d, 0>(ud, u0, n, sd, 1, Ad, X, Id, i, nu) + transport<d, 1>(ud, u1, n, sd, sy, Ad, Y, Id, j, nu) +
                 transport<d, 2>(ud, u2, n, sd, sz, Ad, Z, Id, k, nu);
  out[n] = ud[n] - gdt * r + zdt * N[n] - adt * (pp[n] - pp[n - sd]) * Ad.idf[Id];
  N[n] = -r;
}

struct PredictArgs {
  AxisView A[3];
  const real* U[3];
  const real* p;
  real *N[3], *out[3];
  real nu, gdt, zdt, adt;
};

FLAPSTAB_KERNEL void predict_plane(const Shape& s, int k, const PredictArgs& a) {
  // Everything the loop reads into locals: stores through N and out then cannot alias it, so it vectorises.
  const AxisView X = a.A[0], Y = a.A[1], Z = a.A[2];
  const real *u0 = a.U[0], *u1 = a.U[1], *u2 = a.U[2], *p = a.p;
  real *N0 = a.N[0], *N1 = a.N[1], *N2 = a.N[2], *o0 = a.out[0], *o1 = a.out[1], *o2 = a.out[2];
  const real nu = a.nu, gdt = a.gdt, zdt = a.zdt, adt = a.adt;
  const std::ptrdiff_t sy = s.sy, sz = s.sz;
  for (int j = 1; j <= s.ny; ++j) {
    const std::ptrdiff_t row = s(0, j, k);
#pragma omp simd
    for (int i = 1; i <= s.nx; ++i) {
      predict_point<0>(u0, u1, u2, p, N0, o0, row + i, sy, sz, X, Y, Z, i, j, k, nu, gdt, zdt, adt);
      predict_point<1>(u0, u1, u2, p, N1, o1, row + i, sy, sz, X, Y, Z, i, j, k, nu, gdt, zdt, adt);
      predict_point<2>(u0, u1, u2, p, N2, o2, row + i, sy, sz, X, Y, Z, i, j, k, nu, gdt, zdt, adt);
    }
  }
}

FLAPSTAB_KERNEL void divergence_plane(const Grid& g, int k, const VectorField& u, Field& div, real scale) {
  const Shape& s = div.shape();
  const real* __restrict ix = g.axis[0].idc.data();
  const real* __restrict u0 = u[0].data();
  const real* __restrict u1 = u[1].data();
  const real* __restrict u2 = u[2].data();
  real* __restrict out = div.data();
  const real izk = g.axis[2].idc[k];
  for (int j = 1; j <= s.ny; ++j) {
    const std::ptrdiff_t row = s(0, j, k);
    const real iyj = g.axis[1].idc[j];
#pragma omp simd
    for (int i = 1; i <= s.nx; ++i) {
      const std::ptrdiff_t n = row + i;
      out[n] = scale * ((u0[n + 1] - u0[n]) * ix[i] + (u1[n + s.sy] - u1[n]) * iyj + (u2[n + s.sz] - u2[n]) * izk);
    }
  }
}

// u_d = u*_d - alpha dt (phi[I] - phi[I-1]) / df_d on the lower faces of plane k's cells, and p += phi.
FLAPSTAB_KERNEL void project_plane(const Grid& g, int k, const VectorField& ustar, const Field& phi, VectorField& u,
                                   Field& p, real adt) {
  const Shape& s = p.shape();
  const real* __restrict f = phi.data();
  const real* __restrict ix = g.axis[0].idf.data();
  const real *__restrict s0 = ustar[0].data(), *__restrict s1 = ustar[1].data(), *__restrict s2 = ustar[2].data();
  real *__restrict u0 = u[0].data(), *__restrict u1 = u[1].data(), *__restrict u2 = u[2].data();
  real* __restrict q = p.data();
  const real czk = adt * g.axis[2].idf[k];
  for (int j = 1; j <= s.ny; ++j) {
    const std::ptrdiff_t row = s(0, j, k);
    const real cyj = adt * g.axis[1].idf[j];
#pragma omp simd
    for (int i = 1; i <= s.nx; ++i) {
      const std::ptrdiff_t n = row + i;
      u0[n] = s0[n] - adt * (f[n] - f[n - 1]) * ix[i];
      u1[n] = s1[n] - cyj * (f[n] - f[n - s.sy]);
      u2[n] = s2[n] - czk * (f[n] - f[n - s.sz]);
      q[n] += f[n];
    }
  }
}

// sum_a max(|u_a| on the cell's two a-faces) / dx_a of cell n (inverse widths ixi, iyj, izk).
inline real cell_rate(const Shape& s, const real* __restrict u0, const real* __restrict u1,
                      const real* __restrict u2, std::ptrdiff_t n, real ixi, real iyj, real izk) {
  return std::max(std::abs(u0[n]), std::abs(u0[n + 1])) * ixi + std::max(std::abs(u1[n]), std::abs(u1[n + s.sy])) * iyj +
         std::max(std::abs(u2[n]), std::abs(u2[n + s.sz])) * izk;
}

FLAPSTAB_KERNEL double max_rate_plane(const Grid& g, int k, const VectorField& u) {
  const Shape s = g.shape();
  const real* __restrict ix = g.axis[0].idc.data();
  const real *__restrict u0 = u[0].data(), *__restrict u1 = u[1].data(), *__restrict u2 = u[2].data();
  double m = 0;
  for (int j = 1; j <= s.ny; ++j) {
    const std::ptrdiff_t row = s(0, j, k);
    const real iyj = g.axis[1].idc[j], izk = g.axis[2].idc[k];
#pragma omp simd reduction(max : m)
    for (int i = 1; i <= s.nx; ++i) m = std::max(m, double(cell_rate(s, u0, u1, u2, row + i, ix[i], iyj, izk)));
  }
  return m;
}

}  // namespace

void predict(const Grid& g, const VectorField& u, const Field& p, VectorField& Nprev, VectorField& ustar, double nu,
             double dt, const StageCoefficients& c) {
  // All three components in one pass over the lower faces of every cell (u, v, w are read once); the values on
  // boundary faces are overwritten by impose_normal_velocity.
  const Shape& s = p.shape();
  const PredictArgs a{{AxisView(g.axis[0]), AxisView(g.axis[1]), AxisView(g.axis[2])},
                      {u[0].data(), u[1].data(), u[2].data()},
                      p.data(),
                      {Nprev[0].data(), Nprev[1].data(), Nprev[2].data()},
                      {ustar[0].data(), ustar[1].data(), ustar[2].data()},
                      real(nu), real(c.gamma * dt), real(c.zeta * dt), real(c.alpha() * dt)};
#pragma omp parallel for schedule(static) if (threaded(s))
  for (int k = 1; k <= s.nz; ++k) predict_plane(s, k, a);
}

double convective_acceleration(const Grid& g, const VectorField& u, int d, int i, int j, int k) {
  const Shape& s = u[0].shape();
  const AxisView X(g.axis[0]), Y(g.axis[1]), Z(g.axis[2]);
  const std::ptrdiff_t n = s(i, j, k), sy = s.sy, sz = s.sz;
  const real *u0 = u[0].data(), *u1 = u[1].data(), *u2 = u[2].data();
  if (d == 0)
    return transport<0, 0>(u0, u0, n, 1, 1, X, X, i, i, 0) + transport<0, 1>(u0, u1, n, 1, sy, X, Y, i, j, 0) +
           transport<0, 2>(u0, u2, n, 1, sz, X, Z, i, k, 0);
  if (d == 1)
    return transport<1, 0>(u1, u0, n, sy, 1, Y, X, j, i, 0) + transport<1, 1>(u1, u1, n, sy, sy, Y, Y, j, j, 0) +
           transport<1, 2>(u1, u2, n, sy, sz, Y, Z, j, k, 0);
  return transport<2, 0>(u2, u0, n, sz, 1, Z, X, k, i, 0) + transport<2, 1>(u2, u1, n, sz, sy, Z, Y, k, j, 0) +
         transport<2, 2>(u2, u2, n, sz, sz, Z, Z, k, k, 0);
}

void add_coriolis(const Grid& g, const VectorField& u, VectorField& Nprev, VectorField& ustar, const Vec3& omega,
                  double dt, const StageCoefficients& c) {
  const Shape s = g.shape();
  const real gdt = real(c.gamma * dt);
  for (int d = 0; d < 3; ++d) {
    const int e1 = (d + 1) % 3, e2 = (d + 2) % 3;
    const std::ptrdiff_t sd = s.stride(d), s1 = s.stride(e1), s2 = s.stride(e2);
    // (-2 omega x u)_d = -2 (omega_e1 u_e2 - omega_e2 u_e1)
    const real w1 = real(-2 * omega[e1]), w2 = real(-2 * omega[e2]);
    const real* u1 = u[e1].data();
    const real* u2 = u[e2].data();
    real* N = Nprev[d].data();
    real* us = ustar[d].data();
    int hi[3] = {s.nx, s.ny, s.nz};
    if (g.axis[std::size_t(d)].owns_upper_face()) hi[d] += 1;
    const Axis& A = g.axis[std::size_t(d)];
#pragma omp parallel for schedule(static) if (threaded(s))
    for (int k = 1; k <= hi[2]; ++k)
      for (int j = 1; j <= hi[1]; ++j)
        for (int i = 1; i <= hi[0]; ++i) {
          const std::ptrdiff_t m = s(i, j, k);
          // u_e at this d-face: along e the mean of the two faces of each cell (the centre is their midpoint),
          // along d linear between the two cells' centres (exact for a linear field on a stretched grid).
          const int I[3] = {i, j, k};
          const int id = I[d];
          const double den = A.xc[std::size_t(id)] - A.xc[std::size_t(id - 1)];
          const real w = den > 0 ? real((A.xf[std::size_t(id)] - A.xc[std::size_t(id - 1)]) / den) : real(0.5);
          const real a1 = real(0.5) * ((1 - w) * (u1[m - sd] + u1[m - sd + s1]) + w * (u1[m] + u1[m + s1]));
          const real a2 = real(0.5) * ((1 - w) * (u2[m - sd] + u2[m - sd + s2]) + w * (u2[m] + u2[m + s2]));
          const real C = w1 * a2 - w2 * a1;
          us[m] += gdt * C;
          N[m] += C;
        }
  }
}

void add_rotation(const Grid& g, VectorField& u, const Vec3& w) {
  if (w.squaredNorm() == 0) return;
  const Shape s = g.shape();
  for (int d = 0; d < 3; ++d) {
    const int e1 = (d + 1) % 3, e2 = (d + 2) % 3;
    // (w x r)_d = w_e1 r_e2 - w_e2 r_e1, with r_e at the d-face the cell centre's (e != d)
    const double* c1 = g.axis[std::size_t(e1)].xc.data();
    const double* c2 = g.axis[std::size_t(e2)].xc.data();
    real* v = u[d].data();
    int hi[3] = {s.nx, s.ny, s.nz};
    if (g.axis[std::size_t(d)].owns_upper_face()) hi[d] += 1;
#pragma omp parallel for schedule(static) if (threaded(s))
    for (int k = 1; k <= hi[2]; ++k)
      for (int j = 1; j <= hi[1]; ++j)
        for (int i = 1; i <= hi[0]; ++i) {
          const int I[3] = {i, j, k};
          v[s(i, j, k)] += real(w[e1] * c2[I[e2]] - w[e2] * c1[I[e1]]);
        }
  }
}

void divergence(const Grid& g, const VectorField& u, Field& div, double scale) {
#pragma omp parallel for schedule(static) if (threaded(div.shape()))
  for (int k = 1; k <= div.shape().nz; ++k) divergence_plane(g, k, u, div, real(scale));
}

void project(const Grid& g, const VectorField& ustar, const Field& phi, VectorField& u, Field& p, double alpha_dt) {
  const Shape& s = p.shape();
#pragma omp parallel for schedule(static) if (threaded(s))
  for (int k = 1; k <= s.nz; ++k) project_plane(g, k, ustar, phi, u, p, real(alpha_dt));
  // The upper boundary faces (index n + 1) of non-periodic axes: prescribed (zero correction through a Neumann
  // ghost) or outflow (corrected through the Dirichlet ghost).
  for (int d = 0; d < 3; ++d) {
    if (!g.axis[d].owns_upper_face()) continue;
    const int b = (d + 1) % 3, c = (d + 2) % 3, n = s.n(d);
    const std::ptrdiff_t sd = s.stride(d);
    const real w = real(alpha_dt) * g.axis[d].idf[n + 1];
    for (int kc = 1; kc <= s.n(c); ++kc)
      for (int kb = 1; kb <= s.n(b); ++kb) {
        const std::ptrdiff_t m = (n + 1) * sd + kb * s.stride(b) + kc * s.stride(c);
        u[d][m] = ustar[d][m] - w * (phi[m] - phi[m - sd]);
      }
  }
}

double kinetic_energy(const Grid& g, const VectorField& u) {
  double e = 0;
  for (int d = 0; d < 3; ++d) {
    const Axis &a0 = g.axis[0], &a1 = g.axis[1], &a2 = g.axis[2];
    const real* ud = u[d].data();
    double ed = 0;
    const Shape s = g.shape();
    int hi[3] = {s.nx, s.ny, s.nz};
    if (g.axis[d].owns_upper_face()) ++hi[d];
#pragma omp parallel for schedule(static) reduction(+ : ed) if (threaded(s))
    for (int k = 1; k <= hi[2]; ++k)
      for (int j = 1; j <= hi[1]; ++j)
        for (int i = 1; i <= hi[0]; ++i) {
          const double w = (d == 0 ? a0.dv[i] : a0.dc[i]) * (d == 1 ? a1.dv[j] : a1.dc[j]) * (d == 2 ? a2.dv[k] : a2.dc[k]);
          const double v = ud[s(i, j, k)];
          ed += 0.5 * w * v * v;
        }
    e += ed;
  }
  return e;
}

double viscous_dissipation(const Grid& g, const VectorField& u, double nu) {
  const Shape s = g.shape();
  const int n[3] = {s.nx, s.ny, s.nz};
  const std::ptrdiff_t st[3] = {1, s.sy, s.sz};
  double total = 0;
  for (int d = 0; d < 3; ++d) {
    const real* ud = u[d].data();
    int lo[3] = {1, 1, 1};
    if (!g.axis[d].lower_face_unknown()) lo[d] = 2;  // the boundary faces along d are not unknowns
    double acc = 0;
#pragma omp parallel for schedule(static) reduction(+ : acc) if (threaded(s))
    for (int k = lo[2]; k <= n[2]; ++k)
      for (int j = lo[1]; j <= n[1]; ++j)
        for (int i = lo[0]; i <= n[0]; ++i) {
          const int I[3] = {i, j, k};
          const std::ptrdiff_t m = s(i, j, k);
          double lap = 0, V = 1;
          for (int e = 0; e < 3; ++e) {
            const Axis& a = g.axis[e];
            const std::ptrdiff_t se = st[e];
            if (e == d) {
              lap += ((ud[m + se] - ud[m]) * a.idc[I[e]] - (ud[m] - ud[m - se]) * a.idc[I[e] - 1]) * a.idf[I[e]];
              V *= a.dv[I[e]];
            } else {
              lap += ((ud[m + se] - ud[m]) * a.idf[I[e] + 1] - (ud[m] - ud[m - se]) * a.idf[I[e]]) * a.idc[I[e]];
              V *= a.dc[I[e]];
            }
          }
          acc -= ud[m] * lap * V;
        }
    total += acc;
  }
  return nu * total;
}

double max_divergence(const Grid& g, const VectorField& u) {
  Field div(g.shape());
  divergence(g, u, div, 1.0);
  const Shape s = g.shape();
  double m = 0;
#pragma omp parallel for schedule(static) reduction(max : m) if (threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) m = std::max(m, std::abs(double(div(i, j, k))));
  return m;
}

double max_rate(const Grid& g, const VectorField& u) {
  double m = 0;
#pragma omp parallel for schedule(static) reduction(max : m) if (threaded(g.shape()))
  for (int k = 1; k <= g.shape().nz; ++k) m = std::max(m, max_rate_plane(g, k, u));
  return m;
}

RateLocation max_rate_location(const Grid& g, const VectorField& u) {
  const Shape s = g.shape();
  RateLocation best;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const double r = cell_rate(s, u[0].data(), u[1].data(), u[2].data(), s(i, j, k), g.axis[0].idc[i],
                                   g.axis[1].idc[j], g.axis[2].idc[k]);
        if (!(r <= best.rate)) {  // NaN wins: it is where the flow broke
          best = {i, j, k,
                  Vec3(g.axis[0].xc[std::size_t(i)], g.axis[1].xc[std::size_t(j)], g.axis[2].xc[std::size_t(k)]), r};
          if (std::isnan(r)) return best;
        }
      }
  return best;
}

double max_viscous_rate(const Grid& g, double nu) {
  double m[3];
  for (int a = 0; a < 3; ++a) {
    const double h = g.axis[a].min_width();
    m[a] = 1 / (h * h);
  }
  return nu * (m[0] + m[1] + m[2]);
}

}  // namespace flapstab::ns
