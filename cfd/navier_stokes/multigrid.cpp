// Single-precision geometric multigrid V-cycle for the MAC Laplacian (see multigrid.hpp).
#include "cfd/navier_stokes/multigrid.hpp"
#include <omp.h>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include "cfd/navier_stokes/krylov.hpp"

namespace flapstab::ns {

namespace {

using mg = float;
constexpr int dense_cells = 1024;  // largest coarsest level solved by LU
// Over-relaxation of the red-black smoother: 1.3 keeps the uniform-grid rate (0.06 per preconditioned CG
// iteration) and lowers the stretched-grid one (0.27 -> 0.20 with widths from h to 2.9 h); cf. Yavneh 1996,
// SIAM J Sci Comput 17:180, on over-relaxed red-black smoothing.
constexpr mg omega = 1.3f;

}  // namespace

struct Multigrid::Level {
  Grid grid;
  ScalarBCs bc;
  Stencil<mg> L;
  std::vector<mg> x, b;   // solution, right-hand side (padded like the grid, in the line layout)
  std::vector<mg> idiag;  // 1/diagonal, coarsest level only (the smoother divides: a stored array costs bandwidth)
  int f[3] = {1, 1, 1};         // coarsening factor towards the next level
  // Prolongation from the next coarser level: fine I takes w0 xc[c0] + w1 xc[c1] along each axis.
  std::array<std::vector<int>, 3> c0, c1;
  std::array<std::vector<mg>, 3> w0, w1;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;  // coarsest level
  bool dense = false;
  // Line layout. Split (every level that is smoothed): on each x line the even i come first, at slot i / 2, then
  // the odd i, at slot he + i / 2. A colour's cells of a line are then contiguous, and so are their x neighbours
  // (the other colour's slots, shifted by one), so a red-black half-sweep computes only the cells it updates, in
  // one unit-stride loop. The y and z neighbours keep their slot. Natural (the coarsest level): slot = i.
  bool split = false;
  int he = 0;                                // slots of the even i, 0 .. nx + 1 (split layout)
  std::vector<int> slot;                     // slot of i, 0 .. nx + 1
  std::vector<mg> cxl, cxh, dgx, vx;         // the x-axis stencil coefficients and cell widths, in slot order
  std::vector<int> pc0, pc1;                 // x prolongation in fine slot order, coarse indices as coarse slots
  std::vector<mg> pw0, pw1;

  Slab slab;                // a distributed level: this rank's planes of the whole level
  bool distributed = false;

  Level(Grid g, const ScalarBCs& bc_)
      : grid(std::move(g)), bc(bc_), L(grid, bc), x(L.s.size(), 0), b(L.s.size(), 0) {}
  int threads() const { return threaded(L.s) ? std::max(1, std::min(omp_get_max_threads(), L.s.nz / 4)) : 1; }
  int evens() const { return L.s.nx / 2; }         // even i of 1 .. nx: slots 1 .. evens()
  int odds() const { return (L.s.nx + 1) / 2; }    // odd i of 1 .. nx: slots he .. he + odds() - 1

  void set_layout(bool split_lines) {
    split = split_lines;
    const Shape& s = L.s;
    he = split ? (s.nx + 3) / 2 : 0;
    slot.assign(s.nx + 2, 0);
    for (int i = 0; i <= s.nx + 1; ++i) slot[i] = !split ? i : i % 2 == 0 ? i / 2 : he + i / 2;
    auto permuted = [&](const std::vector<mg>& a) {
      std::vector<mg> p(a.size());
      for (int i = 0; i <= s.nx + 1; ++i) p[slot[i]] = a[i];
      return p;
    };
    cxl = permuted(L.cl[0]);
    cxh = permuted(L.ch[0]);
    dgx = permuted(L.dg[0]);
    vx = permuted(L.vol[0]);
    if (split) return;
    idiag.assign(s.size(), 0);
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) idiag[s(0, j, k) + i] = mg(1.0 / (double(L.dg[0][i]) + L.dg[1][j] + L.dg[2][k]));
  }
};

namespace {

using Level = Multigrid::Level;

// Periodic ghosts in x and y of plane k (the 7-point stencil never reads edge or corner ghosts; the y ghost lines
// are copied whole, which is layout-blind).
void fill_plane_ghosts(Level& V, int k) {
  const Shape& s = V.L.s;
  mg* x = V.x.data();
  if (V.L.periodic[0]) {
    const int g0 = V.slot[0], g1 = V.slot[s.nx + 1], i1 = V.slot[1], in = V.slot[s.nx];
    for (int j = 1; j <= s.ny; ++j) {
      mg* r = x + s(0, j, k);
      r[g0] = r[in];
      r[g1] = r[i1];
    }
  }
  if (V.L.periodic[1]) {
    std::copy_n(x + s(0, s.ny, k), s.sy, x + s(0, 0, k));
    std::copy_n(x + s(0, 1, k), s.sy, x + s(0, s.ny + 1, k));
  }
}

// Box-condition ghosts of a whole level, on its line layout.
void fill_level_ghosts(Level& V) { fill_scalar_ghosts(V.L.s, V.x.data(), V.bc, V.split ? V.slot.data() : nullptr); }

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

// The stencil on line (j, k) of a split level (x: the line's first slot): (L x) at slot q, whose x neighbours sit
// at xw[q] and xw[q + 1] in the other colour's half (xw = x + Half::dx). The split-layout StencilRow.
struct SplitRow {
  const mg* __restrict cxl;
  const mg* __restrict cxh;
  const mg* __restrict dgx;
  const mg *xs, *xn, *xb, *xt;
  mg cyl, cyh, czl, czh, dyz;
  SplitRow(const Level& V, const mg* x, int j, int k)
      : cxl(V.cxl.data()), cxh(V.cxh.data()), dgx(V.dgx.data()), xs(x - V.L.s.sy), xn(x + V.L.s.sy),
        xb(x - V.L.s.sz), xt(x + V.L.s.sz), cyl(V.L.cl[1][j]), cyh(V.L.ch[1][j]), czl(V.L.cl[2][k]),
        czh(V.L.ch[2][k]), dyz(V.L.dg[1][j] + V.L.dg[2][k]) {}
  mg diag(int q) const { return dgx[q] + dyz; }
  mg apply(const mg* x, const mg* xw, int q) const {
    return cxl[q] * xw[q] + cxh[q] * xw[q + 1] + cyl * xs[q] + cyh * xn[q] + czl * xb[q] + czh * xt[q] + diag(q) * x[q];
  }
};
// The slots of one colour's half of a line (odd: the odd i) and the offset of their left x neighbour.
struct Half {
  int lo, hi, dx;
  Half(const Level& V, bool odd)
      : lo(odd ? V.he : 1), hi(odd ? V.he + V.odds() - 1 : V.evens()), dx(odd ? -V.he : V.he - 1) {}
};

// Over-relaxed Gauss-Seidel update x += omega (b - L x) / diagonal of the cells of one colour on plane k
// ((i + j + k) % 2 == colour), on the split line layout: per line one unit-stride loop over that colour's slots.
// `zero`: x is taken as 0 and the other colour set to 0, and b is first read from the double field rd if given.
// zd: receives the plane's final values (the last update of a cycle). The residual form keeps the fixed point
// exact.
FLAPSTAB_KERNEL void relax_plane(Level& V, int k, int colour, bool zero, const real* rd, real* zd) {
  const Shape& s = V.L.s;
  const int he = V.he, ne = V.evens(), no = V.odds();
  for (int j = 1; j <= s.ny; ++j) {
    const std::ptrdiff_t o = s(0, j, k);
    mg* __restrict x = V.x.data() + o;
    mg* __restrict b = V.b.data() + o;
    const bool odd = ((colour + j + k) & 1) != 0;  // this colour's cells have odd i
    const Half h(V, odd);
    const int lo = h.lo, hi = h.hi;
    const SplitRow r(V, x, j, k);
    if (zero) {
      if (rd) {
        const real* __restrict r = rd + o;
#pragma omp simd
        for (int m = 1; m <= ne; ++m) b[m] = mg(r[2 * m]);
#pragma omp simd
        for (int m = 0; m < no; ++m) b[he + m] = mg(r[2 * m + 1]);
      }
#pragma omp simd
      for (int q = lo; q <= hi; ++q) x[q] = b[q] / r.diag(q);
      const Half other(V, !odd);
      std::fill(x + other.lo, x + other.hi + 1, mg(0));
      continue;
    }
    const mg* __restrict xw = x + h.dx;  // x neighbours in the other colour's half
#pragma omp simd
    for (int q = lo; q <= hi; ++q) {
      const mg id = mg(1) / r.diag(q);  // the form of the stored-inverse smoother it replaced (x + omega id r)
      x[q] = x[q] + omega * id * (b[q] - r.apply(x, xw, q));
    }
    if (zd) {  // merge the halves: one loop that stores both i = 2m and 2m + 1 vectorises, two strided ones do not
      real* __restrict z = zd + o;
      const mg* __restrict xo = x + he;
      z[1] = real(xo[0]);
      const int pairs = (s.nx - 1) / 2;
#pragma omp simd
      for (int m = 1; m <= pairs; ++m) {
        z[2 * m] = real(x[m]);
        z[2 * m + 1] = real(xo[m]);
      }
      if (s.nx % 2 == 0) z[s.nx] = real(x[s.nx / 2]);
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

// `count` red-black sweeps (colour `first`, then the other, repeated) in one pass over memory, for levels whose z
// ghosts are not periodic images. Stage s (0 .. 2 count - 1) of a plane updates colour first ^ (s & 1) and needs
// stage s - 1 done on the plane and on both neighbours; each thread runs a wavefront over its slab of planes
// (stage s on plane k - s), so a plane's data stay in cache for all the stages. A slab's end planes depend on
// the neighbouring slabs: in phase m a thread takes their stage from the previous phase's record (a barrier
// apart), so every plane has stage m done after phase m, and 2 count phases finish the sweeps. zero, rd: as in
// relax_plane (first stage); zd: receives the result (last stage).
void fused_sweeps(Level& V, int first, int count, bool zero, const real* rd, real* zd) {
  const int nz = V.L.s.nz, stages = 2 * count;
  std::vector<int> done(nz + 2, 0), seen(nz + 2, 0);
  done[0] = done[nz + 1] = seen[0] = seen[nz + 1] = stages;  // wall ghosts: the stencil does not read them
#pragma omp parallel num_threads(V.threads())
  {
    const int t = omp_get_thread_num(), T = omp_get_num_threads();
    const int a = 1 + nz * t / T, b = nz * (t + 1) / T;
    for (int phase = 0; phase < stages; ++phase) {
      for (int k = a; k <= b + stages - 1; ++k)
        for (int st = 0; st < stages; ++st) {
          const int p = k - st;
          if (p < a || p > b || done[p] != st) continue;
          const int lo = p - 1 >= a ? done[p - 1] : seen[p - 1], hi = p + 1 <= b ? done[p + 1] : seen[p + 1];
          if (lo < st || hi < st) continue;
          relax_plane(V, p, first ^ (st & 1), zero && st == 0, st == 0 ? rd : nullptr, st + 1 == stages ? zd : nullptr);
          done[p] = st + 1;
        }
#pragma omp barrier
#pragma omp single
      seen = done;
    }
  }
}

// One colour's half-sweep on every plane of a distributed level (its z ghosts exchanged before): the neighbours'
// planes are the other rank's, so the planes are not fused into one pass as on a single rank. Local and global
// plane parities agree (slab offsets are even on these levels), so the colouring is the single-rank one.
void sweep_slab(Level& V, int colour, bool zero, const real* rd, real* zd) {
#pragma omp parallel for schedule(static) num_threads(V.threads())
  for (int k = 1; k <= V.L.s.nz; ++k) relax_plane(V, k, colour, zero, rd, zd);
}

// Coarse right-hand side on the coarse line (J, K): volume-weighted mean of the fine residual b - L x (fine level
// split, coarse level in its own layout; acc is indexed by fine slot). The coarse line is K + koff of C (koff > 0:
// C is a whole level and F this rank's slab).
FLAPSTAB_KERNEL void restrict_line(const Level& F, Level& C, int J, int K, mg* acc, int koff) {
  const Shape &s = C.L.s, &fs = F.L.s;
  const mg* __restrict vx = F.vx.data();
  mg* __restrict ac = acc;
  std::fill(ac, ac + fs.nx + 2, mg(0));
  for (int k = F.f[2] * (K - 1) + 1; k <= F.f[2] * K; ++k)
    for (int j = F.f[1] * (J - 1) + 1; j <= F.f[1] * J; ++j) {
      const std::ptrdiff_t o = fs(0, j, k);
      const mg* __restrict x = F.x.data() + o;
      const mg* __restrict br = F.b.data() + o;
      const SplitRow r(F, x, j, k);
      const mg vjk = F.L.vol[1][j] * F.L.vol[2][k];
      for (bool odd : {false, true}) {
        const Half h(F, odd);
        const mg* __restrict xw = x + h.dx;
#pragma omp simd
        for (int q = h.lo; q <= h.hi; ++q) ac[q] += vjk * vx[q] * (br[q] - r.apply(x, xw, q));
      }
    }
  mg* __restrict out = C.b.data() + s(0, J, K + koff);
  const mg* __restrict cvx = C.vx.data();
  const int* __restrict fsl = F.slot.data();
  const int* __restrict csl = C.slot.data();
  const mg ivjk = 1 / (C.L.vol[1][J] * C.L.vol[2][K + koff]);
  if (F.f[0] == 2) {
    for (int I = 1; I <= s.nx; ++I) out[csl[I]] = (ac[fsl[2 * I - 1]] + ac[fsl[2 * I]]) * ivjk / cvx[csl[I]];
  } else {
    for (int I = 1; I <= s.nx; ++I) out[csl[I]] = ac[fsl[I]] * ivjk / cvx[csl[I]];
  }
}

void restrict_residual(const Level& F, Level& C, int koff) {
  const int nK = F.L.s.nz / F.f[2];  // C's planes below F's planes (all of C's unless C is whole and F a slab)
#pragma omp parallel num_threads(F.threads())
  {
    std::vector<mg> acc(F.L.s.nx + 2);
#pragma omp for schedule(static)
    for (int K = 1; K <= nK; ++K)
      for (int J = 1; J <= C.L.s.ny; ++J) restrict_line(F, C, J, K, acc.data(), koff);
  }
}

// Fine x += linear interpolation of the coarse correction on fine plane k (the coarse ghosts carry the BCs). The
// coarse line is interpolated in y and z slot by slot, then in x through the fine level's slot-ordered tables.
FLAPSTAB_KERNEL void prolong_plane(Level& F, const Level& C, int k, mg* line) {
  const Shape &s = F.L.s, &cs = C.L.s;
  const mg* xc = C.x.data();
  const int* __restrict c0x = F.pc0.data();
  const int* __restrict c1x = F.pc1.data();
  const mg* __restrict w0x = F.pw0.data();
  const mg* __restrict w1x = F.pw1.data();
  const int he = F.he, ne = F.evens(), no = F.odds();
  mg* __restrict ln = line;
  for (int j = 1; j <= s.ny; ++j) {
    const mg wy0 = F.w0[1][j], wy1 = F.w1[1][j], wz0 = F.w0[2][k], wz1 = F.w1[2][k];
    const mg* __restrict r00 = xc + cs(0, F.c0[1][j], F.c0[2][k]);
    const mg* __restrict r10 = xc + cs(0, F.c1[1][j], F.c0[2][k]);
    const mg* __restrict r01 = xc + cs(0, F.c0[1][j], F.c1[2][k]);
    const mg* __restrict r11 = xc + cs(0, F.c1[1][j], F.c1[2][k]);
#pragma omp simd
    for (int Q = 0; Q <= cs.nx + 1; ++Q) ln[Q] = wz0 * (wy0 * r00[Q] + wy1 * r10[Q]) + wz1 * (wy0 * r01[Q] + wy1 * r11[Q]);
    mg* __restrict xr = F.x.data() + s(0, j, k);
#pragma omp simd
    for (int q = 1; q <= ne; ++q) xr[q] += w0x[q] * ln[c0x[q]] + w1x[q] * ln[c1x[q]];
#pragma omp simd
    for (int q = he; q < he + no; ++q) xr[q] += w0x[q] * ln[c0x[q]] + w1x[q] * ln[c1x[q]];
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

namespace {

// The whole grids of the hierarchy, finest first, and the coarsening factors from each to the next.
struct Hierarchy {
  std::vector<Grid> grids;
  std::vector<std::array<int, 3>> f;
};

Hierarchy hierarchy(const Grid& g) {
  Hierarchy h;
  h.grids.push_back(g);
  for (;;) {
    const Grid& F = h.grids.back();
    // Coarsen the directions whose spacing is within 2x the smallest (coarse cells must not flatten, which point
    // smoothers handle badly), or every direction that can if none of those can.
    std::array<bool, 3> c{}, can{};
    double hmin = 1e300;
    for (int a = 0; a < 3; ++a) hmin = std::min(hmin, F.axis[a].min_width());
    for (int a = 0; a < 3; ++a) {
      can[a] = F.axis[a].can_coarsen();
      c[a] = can[a] && F.axis[a].min_width() <= 2 * hmin * (1 + 1e-12);
    }
    if (!(c[0] || c[1] || c[2])) c = can;
    if (!(c[0] || c[1] || c[2])) break;
    Grid coarse(c[0] ? F.axis[0].coarsened() : F.axis[0], c[1] ? F.axis[1].coarsened() : F.axis[1],
                c[2] ? F.axis[2].coarsened() : F.axis[2]);
    h.f.push_back({c[0] ? 2 : 1, c[1] ? 2 : 1, c[2] ? 2 : 1});
    h.grids.push_back(std::move(coarse));
  }
  return h;
}

// The block of planes a slab is made of: a z coarsening factor F of the hierarchy with at least `ranks` blocks. The
// largest F whose blocks share out within 10 % (the busiest rank's planes against the mean), so that more levels
// are distributed; the most even split if none does.
int z_unit_of(const Hierarchy& h, int ranks) {
  const int nz = h.grids[0].axis[2].n;
  int F = 1, unit = 1, even = 1;
  double best = 1e300;
  for (const auto& f : h.f) {
    F *= f[2];
    if (f[2] == 1 || nz / F < ranks) continue;
    const int units = nz / F;
    const double imbalance = double((units + ranks - 1) / ranks) * ranks / units;
    if (imbalance <= 1.1) unit = F;
    if (imbalance <= best) {
      best = imbalance;
      even = F;
    }
  }
  return unit > 1 ? unit : even;
}

}  // namespace

int Multigrid::z_unit(const Grid& g, int ranks) { return z_unit_of(hierarchy(g), ranks); }

Slab Multigrid::rank_slab(const Grid& g, const Decomposition& dec) {
  if (!dec.distributed()) return Slab{0, g.axis[2].n, false, false};
  return dec.slab(g.axis[2].n, z_unit(g, dec.size()), g.axis[2].periodic);
}

Multigrid::Multigrid(const Grid& g, const ScalarBCs& bc, std::shared_ptr<const Decomposition> dec)
    : bc_(bc), dec_(std::move(dec)) {
  singular_ = std::none_of(bc.begin(), bc.end(), [](ScalarBC b) { return b == ScalarBC::dirichlet; });
  const Hierarchy h = hierarchy(g);
  const int levels = int(h.grids.size());
  if (dec_ && dec_->distributed()) {
    const int unit = z_unit_of(h, dec_->size());
    if (unit < 2)
      throw std::invalid_argument("multigrid: the z axis of " + std::to_string(g.axis[2].n) +
                                  " cells cannot be split over " + std::to_string(dec_->size()) +
                                  " ranks (it must coarsen at least once, leaving a block of 2 planes per rank)");
    int F = 1;
    for (int l = 0; l < levels; ++l) {
      slabs_.push_back(dec_->slabs(h.grids[std::size_t(l)].axis[2].n, unit / F, g.axis[2].periodic));
      if (F == unit || l + 1 == levels) {
        gathered_ = l;
        break;
      }
      F *= h.f[std::size_t(l)][2];
    }
  }
  for (int l = 0; l < levels; ++l) {
    if (l < gathered_) {
      const Slab& sl = slabs_[std::size_t(l)][std::size_t(dec_->rank())];
      ScalarBCs local = bc;
      if (sl.cut_lo) local[std::size_t(face(2, 0))] = ScalarBC::interface;
      if (sl.cut_hi) local[std::size_t(face(2, 1))] = ScalarBC::interface;
      Level& V = levels_.emplace_back(h.grids[std::size_t(l)].slice_z(sl), local);
      V.slab = sl;
      V.distributed = true;
    } else {
      levels_.emplace_back(h.grids[std::size_t(l)], bc);
    }
    if (l + 1 < levels)
      for (int a = 0; a < 3; ++a) levels_.back().f[a] = h.f[std::size_t(l)][std::size_t(a)];
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
        // A slab prolonged from a whole level: its coarse cells sit at the slab's offset there.
        const int off = a == 2 && F.distributed && !C.distributed ? F.slab.offset / 2 : 0;
        const int Cc = (I + 1) / 2 + off, Cn = (I % 2 == 1) ? Cc - 1 : Cc + 1;
        const double t = (fa.xc[I] - ca.xc[Cc]) / (ca.xc[Cn] - ca.xc[Cc]);
        F.c0[a][I] = Cc;
        F.c1[a][I] = Cn;
        F.w0[a][I] = mg(1 - t);
        F.w1[a][I] = mg(t);
      }
    }
  }
  for (std::size_t l = 0; l < levels_.size(); ++l) levels_[l].set_layout(l + 1 < levels_.size());
  for (std::size_t l = 0; l + 1 < levels_.size(); ++l) {
    Level &F = levels_[l], &C = levels_[l + 1];
    const int n = F.L.s.nx;
    F.pc0.assign(n + 2, 0);
    F.pc1.assign(n + 2, 0);
    F.pw0.assign(n + 2, 0);
    F.pw1.assign(n + 2, 0);
    for (int i = 1; i <= n; ++i) {
      F.pc0[F.slot[i]] = C.slot[F.c0[0][i]];
      F.pc1[F.slot[i]] = C.slot[F.c1[0][i]];
      F.pw0[F.slot[i]] = F.w0[0][i];
      F.pw1[F.slot[i]] = F.w1[0][i];
    }
  }
  if (levels_.back().L.s.cells() <= std::size_t(dense_cells)) factor_dense(levels_.back(), singular_);
}

Multigrid::~Multigrid() = default;
Multigrid::Multigrid(Multigrid&&) noexcept = default;
Multigrid& Multigrid::operator=(Multigrid&&) noexcept = default;

int Multigrid::levels() const { return int(levels_.size()); }
const Shape& Multigrid::level_shape(int l) const { return levels_.at(l).L.s; }

void Multigrid::exchange(Level& V) const { dec_->exchange(V.x.data(), V.L.s, V.slab); }

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
    if (r) std::transform(r, r + V.b.size(), V.b.begin(), [](real v) { return mg(v); });  // a one-level grid
    solve_coarsest(V, singular_, bc_);
    if (z) std::copy(V.x.begin(), V.x.end(), z);
    return;
  }
  Level& C = levels_[l + 1];
  if (V.distributed) {  // a rank's slab: a ghost exchange after each half-sweep that neighbours read
    for (int s = 0; s < pre; ++s) {
      if (s > 0) exchange(V);
      sweep_slab(V, 0, s == 0, s == 0 ? r : nullptr, nullptr);
      exchange(V);
      sweep_slab(V, 1, false, nullptr, nullptr);
    }
    exchange(V);
    const int koff = C.distributed ? 0 : V.slab.offset / V.f[2];
    restrict_residual(V, C, koff);
    if (!C.distributed) dec_->gather_planes(C.b.data(), C.L.s, slabs_[std::size_t(l + 1)]);
    cycle(l + 1, pre, post, nullptr, nullptr);
    fill_level_ghosts(C);
    if (C.distributed) exchange(C);
    prolong_add(V, C);
    fill_periodic(V);  // x and y images (a slab's z ghosts come with the exchanges below)
    for (int s = 0; s < post; ++s) {
      exchange(V);
      sweep_slab(V, 1, false, nullptr, nullptr);
      exchange(V);
      sweep_slab(V, 0, false, nullptr, s + 1 == post ? z : nullptr);
    }
    return;
  }
  if (V.L.periodic[2])
    for (int s = 0; s < pre; ++s) sweep(V, 0, s == 0, s == 0 ? r : nullptr, nullptr);
  else
    fused_sweeps(V, 0, pre, true, r, nullptr);
  restrict_residual(V, C, 0);
  cycle(l + 1, pre, post, nullptr, nullptr);
  fill_level_ghosts(C);
  prolong_add(V, C);
  fill_periodic(V);
  if (V.L.periodic[2])
    for (int s = 0; s < post; ++s) sweep(V, 1, false, nullptr, s + 1 == post ? z : nullptr);
  else
    fused_sweeps(V, 1, post, false, nullptr, z);
}

}  // namespace flapstab::ns
