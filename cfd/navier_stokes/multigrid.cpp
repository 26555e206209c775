// Single-precision geometric multigrid V-cycle for the MAC Laplacian (see multigrid.hpp).
#include "cfd/navier_stokes/multigrid.hpp"
#include <omp.h>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include "cfd/navier_stokes/krylov.hpp"

namespace flapstab::ns {

namespace {

using mg = float;
constexpr int dense_cells = 1024;  // largest coarsest level solved by LU
constexpr int max_line = 1024;     // line buffer of the smoother (longer lines go in pieces)
// Over-relaxation of the red-black smoother: 1.3 keeps the uniform-grid rate (0.06 per preconditioned CG
// iteration) and lowers the stretched-grid one (0.27 -> 0.20 with widths from h to 2.9 h); cf. Yavneh 1996,
// SIAM J Sci Comput 17:180, on over-relaxed red-black smoothing.
constexpr mg omega = 1.3f;

}  // namespace

struct Multigrid::Level {
  Grid grid;
  Stencil<mg> L;
  std::vector<mg> x, b, idiag;  // solution, right-hand side, 1/diagonal (padded like the grid)
  int f[3] = {1, 1, 1};         // coarsening factor towards the next level
  // Prolongation from the next coarser level: fine I takes w0 xc[c0] + w1 xc[c1] along each axis.
  std::array<std::vector<int>, 3> c0, c1;
  std::array<std::vector<mg>, 3> w0, w1;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;  // coarsest level
  bool dense = false;

  Level(Grid g, const ScalarBCs& bc)
      : grid(std::move(g)), L(grid, bc), x(L.s.size(), 0), b(L.s.size(), 0), idiag(L.s.size(), 0) {
    for (int k = 1; k <= L.s.nz; ++k)
      for (int j = 1; j <= L.s.ny; ++j)
        for (int i = 1; i <= L.s.nx; ++i) idiag[L.s(i, j, k)] = mg(1.0 / (double(L.dg[0][i]) + L.dg[1][j] + L.dg[2][k]));
  }
  int threads() const { return threaded(L.s) ? std::max(1, std::min(omp_get_max_threads(), L.s.nz / 4)) : 1; }
};

namespace {

using Level = Multigrid::Level;

// Periodic ghosts in x and y of plane k (the 7-point stencil never reads edge or corner ghosts).
void fill_plane_ghosts(Level& V, int k) {
  const Shape& s = V.L.s;
  mg* x = V.x.data();
  if (V.L.periodic[0])
    for (int j = 1; j <= s.ny; ++j) {
      mg* r = x + s(0, j, k);
      r[0] = r[s.nx];
      r[s.nx + 1] = r[1];
    }
  if (V.L.periodic[1]) {
    std::copy_n(x + s(1, s.ny, k), s.nx, x + s(1, 0, k));
    std::copy_n(x + s(1, 1, k), s.nx, x + s(1, s.ny + 1, k));
  }
}

void fill_z_ghosts(Level& V) {
  const Shape& s = V.L.s;
  if (!V.L.periodic[2]) return;
  std::copy_n(V.x.data() + s(0, 0, s.nz), s.sz, V.x.data());
  std::copy_n(V.x.data() + s(0, 0, 1), s.sz, V.x.data() + s(0, 0, s.nz + 1));
}

void fill_periodic(Level& V) {
  for (int k = 1; k <= V.L.s.nz; ++k) fill_plane_ghosts(V, k);
  fill_z_ghosts(V);
}

// Over-relaxed Gauss-Seidel update x += omega (b - L x) / diagonal of the cells of one colour on plane k
// ((i + j + k) % 2 == colour). Both colours are computed and one is kept, so the loop vectorises. `zero`: x is
// taken as 0 and the other colour set to 0, and b is first read from the double field rd if given. zd: receives
// the plane's final values (the last update of a cycle). The residual form keeps the fixed point exact.
FLAPSTAB_KERNEL void relax_plane(Level& V, int k, int colour, bool zero, const real* rd, real* zd) {
  const Shape& s = V.L.s;
  const mg* __restrict cxl = V.L.cl[0].data();
  const mg* __restrict cxh = V.L.ch[0].data();
  const mg* __restrict dgx = V.L.dg[0].data();
  mg v[max_line];
  for (int j = 1; j <= s.ny; ++j) {
    const std::ptrdiff_t o = s(0, j, k);
    mg* __restrict x = V.x.data() + o;
    mg* __restrict b = V.b.data() + o;
    const mg* __restrict xs = x - s.sy;
    const mg* __restrict xn = x + s.sy;
    const mg* __restrict xb = x - s.sz;
    const mg* __restrict xt = x + s.sz;
    const mg* __restrict id = V.idiag.data() + o;
    const mg cyl = V.L.cl[1][j], cyh = V.L.ch[1][j], czl = V.L.cl[2][k], czh = V.L.ch[2][k];
    const mg dyz = V.L.dg[1][j] + V.L.dg[2][k];
    const int parity = (colour + j + k) & 1;
    for (int i0 = 1; i0 <= s.nx; i0 += max_line) {
      const int i1 = std::min(s.nx, i0 + max_line - 1);
      if (zero) {
        if (rd) {
          const real* __restrict r = rd + o;
#pragma omp simd
          for (int i = i0; i <= i1; ++i) b[i] = mg(r[i]);
        }
#pragma omp simd
        for (int i = i0; i <= i1; ++i) x[i] = (i & 1) == parity ? b[i] * id[i] : mg(0);
        continue;
      }
      mg* __restrict w = v - i0;
#pragma omp simd
      for (int i = i0; i <= i1; ++i)
        w[i] = x[i] + omega * id[i] *
                          (b[i] - (cxl[i] * x[i - 1] + cxh[i] * x[i + 1] + cyl * xs[i] + cyh * xn[i] + czl * xb[i] +
                                   czh * xt[i] + (dgx[i] + dyz) * x[i]));
#pragma omp simd
      for (int i = i0; i <= i1; ++i) x[i] = (i & 1) == parity ? w[i] : x[i];
      if (zd) {
        real* __restrict z = zd + o;
#pragma omp simd
        for (int i = i0; i <= i1; ++i) z[i] = real(x[i]);
      }
    }
  }
  fill_plane_ghosts(V, k);
}

// One red-black sweep, colour `first` then the other, in a single pass over memory: each thread owns a slab of
// planes and updates the second colour one plane behind the first; a slab's end planes wait for the neighbouring
// slabs (their first-colour neighbours belong to other threads).
void sweep(Level& V, int first, bool zero, const real* rd, real* zd) {
  const int second = 1 - first, nz = V.L.s.nz;
  if (!zero) fill_z_ghosts(V);
#pragma omp parallel num_threads(V.threads())
  {
    const int t = omp_get_thread_num(), T = omp_get_num_threads();
    const int a = 1 + nz * t / T, b = nz * (t + 1) / T;
    for (int k = a; k <= b; ++k) {
      relax_plane(V, k, first, zero, rd, nullptr);
      if (k - 1 >= a + 1) relax_plane(V, k - 1, second, false, nullptr, zd);
    }
#pragma omp barrier
#pragma omp single
    fill_z_ghosts(V);
    relax_plane(V, a, second, false, nullptr, zd);
    if (b != a) relax_plane(V, b, second, false, nullptr, zd);
  }
  fill_z_ghosts(V);
}

// Coarse right-hand side on the coarse line (J, K): volume-weighted mean of the fine residual b - L x.
FLAPSTAB_KERNEL void restrict_line(const Level& F, Level& C, int J, int K, mg* acc) {
  const Shape &s = C.L.s, &fs = F.L.s;
  const mg* __restrict vx = F.L.vol[0].data();
  mg* __restrict ac = acc;
  std::fill(ac, ac + fs.nx + 2, mg(0));
  for (int k = F.f[2] * (K - 1) + 1; k <= F.f[2] * K; ++k)
    for (int j = F.f[1] * (J - 1) + 1; j <= F.f[1] * J; ++j) {
      const StencilRow<mg> r(F.L, F.x.data(), j, k);
      const mg* __restrict br = F.b.data() + fs(0, j, k);
      const mg vjk = F.L.vol[1][j] * F.L.vol[2][k];
#pragma omp simd
      for (int i = 1; i <= fs.nx; ++i) ac[i] += vjk * vx[i] * (br[i] - r.apply(i));
    }
  mg* __restrict out = C.b.data() + s(0, J, K);
  const mg* __restrict cvx = C.L.vol[0].data();
  const mg ivjk = 1 / (C.L.vol[1][J] * C.L.vol[2][K]);
  if (F.f[0] == 2) {
#pragma omp simd
    for (int I = 1; I <= s.nx; ++I) out[I] = (ac[2 * I - 1] + ac[2 * I]) * ivjk / cvx[I];
  } else {
#pragma omp simd
    for (int I = 1; I <= s.nx; ++I) out[I] = ac[I] * ivjk / cvx[I];
  }
}

void restrict_residual(const Level& F, Level& C) {
#pragma omp parallel num_threads(F.threads())
  {
    std::vector<mg> acc(F.L.s.nx + 2);
#pragma omp for schedule(static)
    for (int K = 1; K <= C.L.s.nz; ++K)
      for (int J = 1; J <= C.L.s.ny; ++J) restrict_line(F, C, J, K, acc.data());
  }
}

// Fine x += linear interpolation of the coarse correction on fine plane k (the coarse ghosts carry the BCs).
FLAPSTAB_KERNEL void prolong_plane(Level& F, const Level& C, int k, mg* line) {
  const Shape &s = F.L.s, &cs = C.L.s;
  const mg* xc = C.x.data();
  const int* __restrict c0x = F.c0[0].data();
  const int* __restrict c1x = F.c1[0].data();
  const mg* __restrict w0x = F.w0[0].data();
  const mg* __restrict w1x = F.w1[0].data();
  mg* __restrict ln = line;
  for (int j = 1; j <= s.ny; ++j) {
    const mg wy0 = F.w0[1][j], wy1 = F.w1[1][j], wz0 = F.w0[2][k], wz1 = F.w1[2][k];
    const mg* __restrict r00 = xc + cs(0, F.c0[1][j], F.c0[2][k]);
    const mg* __restrict r10 = xc + cs(0, F.c1[1][j], F.c0[2][k]);
    const mg* __restrict r01 = xc + cs(0, F.c0[1][j], F.c1[2][k]);
    const mg* __restrict r11 = xc + cs(0, F.c1[1][j], F.c1[2][k]);
#pragma omp simd
    for (int I = 0; I <= cs.nx + 1; ++I) ln[I] = wz0 * (wy0 * r00[I] + wy1 * r10[I]) + wz1 * (wy0 * r01[I] + wy1 * r11[I]);
    mg* __restrict xr = F.x.data() + s(0, j, k);
#pragma omp simd
    for (int i = 1; i <= s.nx; ++i) xr[i] += w0x[i] * ln[c0x[i]] + w1x[i] * ln[c1x[i]];
  }
}

void prolong_add(Level& F, const Level& C) {
#pragma omp parallel num_threads(F.threads())
  {
    std::vector<mg> line(C.L.s.nx + 2);
#pragma omp for schedule(static)
    for (int k = 1; k <= F.L.s.nz; ++k) prolong_plane(F, C, k, line.data());
  }
}

// Index of cell (i, j, k) in the dense coarsest matrix, with periodic wrap of ghost indices.
int dense_index(const Shape& s, int i, int j, int k) {
  auto wrap = [](int I, int n) { return I < 1 ? I + n : I > n ? I - n : I; };
  return (wrap(i, s.nx) - 1) + s.nx * ((wrap(j, s.ny) - 1) + s.ny * (wrap(k, s.nz) - 1));
}

void factor_dense(Level& V, bool singular) {
  const Stencil<mg>& L = V.L;
  const Shape& s = L.s;
  const int N = int(s.cells());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(N, N);
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const int r = dense_index(s, i, j, k);
        A(r, r) += L.diag(i, j, k);
        A(r, dense_index(s, i - 1, j, k)) += L.cl[0][i];
        A(r, dense_index(s, i + 1, j, k)) += L.ch[0][i];
        A(r, dense_index(s, i, j - 1, k)) += L.cl[1][j];
        A(r, dense_index(s, i, j + 1, k)) += L.ch[1][j];
        A(r, dense_index(s, i, j, k - 1)) += L.cl[2][k];
        A(r, dense_index(s, i, j, k + 1)) += L.ch[2][k];
      }
  if (singular) {  // pin cell 0: with a compatible b its equation is minus the sum of the others
    A.row(0).setZero();
    A(0, 0) = 1;
  }
  V.lu.compute(A);
  V.dense = true;
}

// Coarsest level, from x = 0: dense LU, or Jacobi-preconditioned CG until the residual dropped 1000-fold.
void solve_coarsest(Level& V, bool singular, const ScalarBCs& bc) {
  const Stencil<mg>& L = V.L;
  const Shape& s = L.s;
  if (singular) {  // make b compatible (the restriction keeps it so up to round-off)
    double sum, vol, max;
    krylov::sum_and_max(L, V.b.data(), sum, vol, max);
    krylov::add_constant(L, V.b.data(), mg(-sum / vol));
  }
  if (V.dense) {
    Eigen::VectorXd rhs(s.cells());
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) rhs(dense_index(s, i, j, k)) = V.b[s(i, j, k)];
    if (singular) rhs(0) = 0;
    const Eigen::VectorXd sol = V.lu.solve(rhs);
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) V.x[s(i, j, k)] = mg(sol(dense_index(s, i, j, k)));
    return;
  }
  const std::size_t n = s.size();
  std::vector<mg> r(V.b), z(n, 0), p(n, 0), q(n, 0);
  double rz_old = 1, r0 = -1;
  for (int it = 0; it < 1000; ++it) {
    for (std::size_t m = 0; m < n; ++m) z[m] = r[m] * V.idiag[m];
    const double rz = krylov::inner(L, r.data(), z.data());
    krylov::axpy_into(L, z.data(), mg(it == 0 ? 0.0 : rz / rz_old), p.data());
    rz_old = rz;
    fill_scalar_ghosts(s, p.data(), bc);
    double pq, pr;
    krylov::apply_and_dot(L, p.data(), q.data(), r.data(), pq, pr);
    const double m = krylov::update(L, V.x.data(), r.data(), p.data(), q.data(), mg(rz / pq), it == 0);
    if (r0 < 0) r0 = m;
    if (m <= 1e-3 * r0) break;
  }
}

}  // namespace

Multigrid::Multigrid(const Grid& g, const ScalarBCs& bc) : bc_(bc) {
  singular_ = std::none_of(bc.begin(), bc.end(), [](ScalarBC b) { return b == ScalarBC::dirichlet; });
  levels_.emplace_back(g, bc);
  for (;;) {
    Level& F = levels_.back();
    // Coarsen the directions whose spacing is within 2x the smallest (coarse cells must not flatten, which point
    // smoothers handle badly), or every direction that can if none of those can.
    std::array<bool, 3> c{}, can{};
    double hmin = 1e300;
    for (int a = 0; a < 3; ++a) hmin = std::min(hmin, F.grid.axis[a].min_width());
    for (int a = 0; a < 3; ++a) {
      can[a] = F.grid.axis[a].can_coarsen();
      c[a] = can[a] && F.grid.axis[a].min_width() <= 2 * hmin * (1 + 1e-12);
    }
    if (!(c[0] || c[1] || c[2])) c = can;
    if (!(c[0] || c[1] || c[2])) break;
    Grid coarse(c[0] ? F.grid.axis[0].coarsened() : F.grid.axis[0], c[1] ? F.grid.axis[1].coarsened() : F.grid.axis[1],
                c[2] ? F.grid.axis[2].coarsened() : F.grid.axis[2]);
    for (int a = 0; a < 3; ++a) F.f[a] = c[a] ? 2 : 1;
    levels_.emplace_back(std::move(coarse), bc);
  }
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l) {
    Level &F = levels_[l], &C = levels_[l + 1];
    for (int a = 0; a < 3; ++a) {
      const Axis &fa = F.grid.axis[a], &ca = C.grid.axis[a];
      const int n = fa.n;
      F.c0[a].assign(n + 2, 0);
      F.c1[a].assign(n + 2, 0);
      F.w0[a].assign(n + 2, 1);
      F.w1[a].assign(n + 2, 0);
      for (int I = 1; I <= n; ++I) {
        if (F.f[a] == 1) {
          F.c0[a][I] = F.c1[a][I] = I;
          continue;
        }
        const int Cc = (I + 1) / 2, Cn = (I % 2 == 1) ? Cc - 1 : Cc + 1;
        const double t = (fa.xc[I] - ca.xc[Cc]) / (ca.xc[Cn] - ca.xc[Cc]);
        F.c0[a][I] = Cc;
        F.c1[a][I] = Cn;
        F.w0[a][I] = mg(1 - t);
        F.w1[a][I] = mg(t);
      }
    }
  }
  if (levels_.back().L.s.cells() <= std::size_t(dense_cells)) factor_dense(levels_.back(), singular_);
}

Multigrid::~Multigrid() = default;
Multigrid::Multigrid(Multigrid&&) noexcept = default;
Multigrid& Multigrid::operator=(Multigrid&&) noexcept = default;

int Multigrid::levels() const { return int(levels_.size()); }
const Shape& Multigrid::level_shape(int l) const { return levels_.at(l).L.s; }

void Multigrid::vcycle(const Field& r, Field& z, int pre, int post) {
  if (!(r.shape() == levels_[0].L.s) || !(z.shape() == levels_[0].L.s))
    throw std::invalid_argument("multigrid: field shape differs from the grid");
  if (pre < 1 || post < 1) throw std::invalid_argument("multigrid: needs at least one pre- and one post-smoothing sweep");
  cycle(0, pre, post, r.data(), z.data());
}

// Pre-smoothing red first from x = 0, post-smoothing black first (a symmetric cycle). Level 0 reads its
// right-hand side from r and leaves its result in z.
void Multigrid::cycle(int l, int pre, int post, const real* r, real* z) {
  Level& V = levels_[l];
  if (l + 1 == int(levels_.size())) {
    solve_coarsest(V, singular_, bc_);
    return;
  }
  Level& C = levels_[l + 1];
  for (int s = 0; s < pre; ++s) sweep(V, 0, s == 0, s == 0 ? r : nullptr, nullptr);
  restrict_residual(V, C);
  cycle(l + 1, pre, post, nullptr, nullptr);
  fill_scalar_ghosts(C.L.s, C.x.data(), bc_);
  prolong_add(V, C);
  fill_periodic(V);
  for (int s = 0; s < post; ++s) sweep(V, 1, false, nullptr, s + 1 == post ? z : nullptr);
}

}  // namespace flapstab::ns
