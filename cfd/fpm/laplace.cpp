// Neumann Laplace problems on the fluid cells (laplace.hpp).
#include "cfd/fpm/laplace.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

namespace flapstab::fpm {

namespace {

using ns::Axis;
using ns::real;

bool periodic_of(const std::array<Axis, 3>& ax, int d) { return ax[std::size_t(d)].periodic; }

// Periodic images of m-valued cells into the ghost layer.
template <int M, class T>
void fill_ghosts_block(const Shape& s, const bool periodic[3], T* x) {
  for (int a = 0; a < 3; ++a) {
    if (!periodic[a]) continue;
    const int b = (a + 1) % 3, c = (a + 2) % 3, n = s.n(a);
    const std::ptrdiff_t sa = s.stride(a), sb = s.stride(b), sc = s.stride(c);
    for (int kc = 0; kc <= s.n(c) + 1; ++kc)
      for (int kb = 0; kb <= s.n(b) + 1; ++kb) {
        T* l = x + (kb * sb + kc * sc) * M;
        for (int q = 0; q < M; ++q) {
          l[q] = l[n * sa * M + q];
          l[(n + 1) * sa * M + q] = l[sa * M + q];
        }
      }
  }
}

void fill_ghosts(const Shape& s, const bool periodic[3], real* x) { fill_ghosts_block<1>(s, periodic, x); }

struct Level {
  std::array<Axis, 3> axis;
  Shape s;
  bool periodic[3] = {false, false, false};
  bool coarsen[3] = {false, false, false};  // coarsened by 2 towards the next level
  Field a[3], diag;

  explicit Level(std::array<Axis, 3> ax) : axis(std::move(ax)), s(axis[0].n, axis[1].n, axis[2].n) {
    for (int d = 0; d < 3; ++d) {
      periodic[d] = periodic_of(axis, d);
      a[d] = Field(s);
    }
    diag = Field(s);
  }

  void finish() {
    for (int d = 0; d < 3; ++d)
      if (periodic[d]) copy_periodic_faces(a[d], s, d);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i)
          diag(i, j, k) = a[0](i, j, k) + a[0](i + 1, j, k) + a[1](i, j, k) + a[1](i, j + 1, k) + a[2](i, j, k) +
                          a[2](i, j, k + 1);
  }

  bool active(std::ptrdiff_t n) const { return diag[n] > 0; }

  // sum of the six neighbours weighted by their conductances
  real off(const real* x, int i, int j, int k) const {
    const std::ptrdiff_t n = s(i, j, k);
    return a[0][n] * x[n - 1] + a[0][n + 1] * x[n + 1] + a[1][n] * x[n - s.sy] + a[1][n + s.sy] * x[n + s.sy] +
           a[2][n] * x[n - s.sz] + a[2][n + s.sz] * x[n + s.sz];
  }

  // out = A x (bv null) or b - A x, zero in inactive cells.
  void apply_or_residual(Field& xv, const Field* bv, Field& out) const {
    fill_ghosts(s, periodic, xv.data());
    const real* xp = xv.data();
    const real* bp = bv ? bv->data() : nullptr;
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          const real ax = active(n) ? diag[n] * xp[n] - off(xp, i, j, k) : 0;
          out[n] = !active(n) ? 0 : bp ? bp[n] - ax : ax;
        }
  }
  void apply(Field& xv, Field& out) const { apply_or_residual(xv, nullptr, out); }
};

// The preconditioner's hierarchy in single precision, for m right-hand sides at once: every per-cell array of m
// values stores them side by side (value r of cell n at n * m + r), so a sweep reads each conductance once for all
// m potentials of a sample (they share the operator) and the red-black colours skip whole groups of m values.
struct BlockLevel {
  Shape s;
  bool periodic[3] = {false, false, false};
  bool coarsen[3] = {false, false, false};
  std::vector<float> a[3], diag, inv_diag;  // inv_diag: 1 / diag, 0 where inactive
  mutable std::vector<float> x, b, r;  // m values per cell (resized for the block at hand)

  explicit BlockLevel(const Level& L) : s(L.s) {
    for (int d = 0; d < 3; ++d) {
      periodic[d] = L.periodic[d];
      coarsen[d] = L.coarsen[d];
      a[d].assign(L.a[d].data(), L.a[d].data() + s.size());
    }
    diag.assign(L.diag.data(), L.diag.data() + s.size());
    inv_diag.resize(s.size());
    const std::ptrdiff_t size = std::ptrdiff_t(s.size());
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (std::ptrdiff_t n = 0; n < size; ++n) {
      const double d = L.diag[n];
      inv_diag[std::size_t(n)] = d > 0 ? float(1 / d) : 0.0f;
    }
  }
  void reserve(int m) const {
    for (auto* v : {&x, &b, &r})
      if (v->size() != std::size_t(m) * s.size()) v->assign(std::size_t(m) * s.size(), 0.0f);
  }
  bool active(std::ptrdiff_t n) const { return diag[std::size_t(n)] > 0; }
};

// out = A x or b - A x (m values per cell) with the conductances of level L (double or float arrays), zero where
// inactive. The value type of x, b, out is T.
template <int M, class C, class T>
FLAPSTAB_KERNEL void block_residual(const Shape& s, const C* a0, const C* a1, const C* a2, const C* diag, const T* x,
                                    const T* b, T* out) {
  const std::ptrdiff_t sy = s.sy, sz = s.sz;
#pragma omp parallel for schedule(static) if (ns::threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const std::ptrdiff_t n = s(i, j, k);
        T* o = out + n * M;
        const C d = diag[n];
        if (!(d > 0)) {
          for (int q = 0; q < M; ++q) o[q] = 0;
          continue;
        }
        const C w0 = a0[n], w1 = a0[n + 1], w2 = a1[n], w3 = a1[n + sy], w4 = a2[n], w5 = a2[n + sz];
        for (int q = 0; q < M; ++q) {
          const T ax = T(d) * x[n * M + q] -
                       (T(w0) * x[(n - 1) * M + q] + T(w1) * x[(n + 1) * M + q] + T(w2) * x[(n - sy) * M + q] +
                        T(w3) * x[(n + sy) * M + q] + T(w4) * x[(n - sz) * M + q] + T(w5) * x[(n + sz) * M + q]);
          o[q] = b ? b[n * M + q] - ax : ax;
        }
      }
}

// Red-black successive over-relaxation on m right-hand sides: colours in the given order, `sweeps` times, x <- (1 -
// omega) x + omega x_GS. With the colours reversed after the coarse correction the V-cycle stays symmetric.
template <int M>
FLAPSTAB_KERNEL void block_smooth(const BlockLevel& L, int sweeps, int first_colour, float omega) {
  const Shape& s = L.s;
  const std::ptrdiff_t sy = s.sy, sz = s.sz;
  const float *a0 = L.a[0].data(), *a1 = L.a[1].data(), *a2 = L.a[2].data(), *id = L.inv_diag.data(),
              *b = L.b.data();
  float* x = L.x.data();
  const float om1 = 1 - omega;
  for (int sw = 0; sw < sweeps; ++sw)
    for (int c = 0; c < 2; ++c) {
      const int colour = (first_colour + c) % 2;
      fill_ghosts_block<M>(s, L.periodic, x);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (int k = 1; k <= s.nz; ++k)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1 + ((j + k + 1 + colour) % 2); i <= s.nx; i += 2) {
            const std::ptrdiff_t n = s(i, j, k);
            const float e = id[n] * omega;
            if (!(e > 0)) continue;
            const float w0 = a0[n], w1 = a0[n + 1], w2 = a1[n], w3 = a1[n + sy], w4 = a2[n], w5 = a2[n + sz];
            for (int q = 0; q < M; ++q)
              x[n * M + q] = om1 * x[n * M + q] +
                             (b[n * M + q] + w0 * x[(n - 1) * M + q] + w1 * x[(n + 1) * M + q] +
                              w2 * x[(n - sy) * M + q] + w3 * x[(n + sy) * M + q] + w4 * x[(n - sz) * M + q] +
                              w5 * x[(n + sz) * M + q]) *
                                 e;
          }
    }
}

template <int M>
std::array<double, M> block_max_abs(const BlockLevel& L, const float* f) {
  std::array<double, M> m{};
  double* mp = m.data();
  const Shape& s = L.s;
#pragma omp parallel for schedule(static) reduction(max : mp[:M]) if (ns::threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const std::ptrdiff_t n = s(i, j, k);
        if (L.active(n))
          for (int q = 0; q < M; ++q) mp[q] = std::max(mp[q], std::abs(double(f[n * M + q])));
      }
  return m;
}

}  // namespace

void fill_periodic_ghosts(const Grid& g, Field& x) {
  const bool p[3] = {g.axis[0].periodic, g.axis[1].periodic, g.axis[2].periodic};
  fill_ghosts(x.shape(), p, x.data());
}

struct NeumannLaplacian::Impl {
  std::optional<Level> fine;       // the operator in double (the conjugate gradients apply it)
  std::vector<BlockLevel> levels;  // the V-cycle's hierarchy in single precision
  // The conjugate gradients' vectors per right-hand side (r, p, q, b), kept from solve to solve and handed on to the
  // next sample's operator (take_workspace) instead of allocated and faulted in per sample. The preconditioned
  // residual z is the V-cycle's own (interleaved, float) solution, read where it is needed.
  mutable std::vector<std::array<Field, 4>> work;
  // Red-black sweeps before and after the coarse-grid correction on every level but the coarsest, over-relaxed. The
  // coarse correction (piecewise-constant prolongation) is weak on these grids, so smoothing carries the
  // convergence: on the hawkmoth benchmark (bench/bench_fpm.cpp, BM_PotentialsFromZero, one thread) Gauss-Seidel
  // (omega 1) with 2, 4, 6 and 8 sweeps took 10.3, 5.7, 4.2 and 4.0 iterations per potential, the whole sample 800,
  // 578, 542 and 537 ms; 4 sweeps with omega 1.3, 1.4, 1.5 and 1.6 took 4.3, 4.0, 4.2 and 5 iterations (487, 395,
  // 454, 485 ms), 3 and 5 sweeps at 1.4 took 5 and 4 (447, 466 ms).
  static constexpr int smoothing = 4;
  static constexpr float omega = 1.4f;

  // V-cycle on level l for m right-hand sides: L.x from zero for L.b.
  template <int M>
  void vcycle(std::size_t l) const {
    const BlockLevel& L = levels[l];
    const Shape& s = L.s;
    std::fill(L.x.begin(), L.x.end(), 0.0f);
    const auto residual = [&] {
      fill_ghosts_block<M>(s, L.periodic, L.x.data());
      block_residual<M>(s, L.a[0].data(), L.a[1].data(), L.a[2].data(), L.diag.data(), L.x.data(), L.b.data(),
                        L.r.data());
    };
    if (l + 1 == levels.size()) {
      // Coarsest level: symmetric sweeps until every residual falls a hundredfold (or 400 sweeps).
      residual();
      const std::array<double, M> r0 = block_max_abs<M>(L, L.r.data());
      if (*std::max_element(r0.begin(), r0.end()) == 0) return;
      for (int it = 0; it < 200; ++it) {
        block_smooth<M>(L, 1, 0, omega);
        block_smooth<M>(L, 1, 1, omega);
        if (it % 10 == 9) {
          residual();
          const std::array<double, M> rn = block_max_abs<M>(L, L.r.data());
          bool done = true;
          for (int q = 0; q < M; ++q) done = done && rn[q] <= 1e-2 * r0[q];
          if (done) break;
        }
      }
      return;
    }
    block_smooth<M>(L, smoothing, 0, omega);
    residual();
    const BlockLevel& C = levels[l + 1];
    const Shape& cs = C.s;
    // Restriction (summed), by coarse plane: the fine planes of one coarse plane belong to it alone.
#pragma omp parallel for schedule(static) if (ns::threaded(cs))
    for (int K = 1; K <= cs.nz; ++K) {
      for (int J = 1; J <= cs.ny; ++J)
        for (int I = 1; I <= cs.nx; ++I)
          for (int q = 0; q < M; ++q) C.b[std::size_t(cs(I, J, K) * M + q)] = 0;
      const int k0 = L.coarsen[2] ? 2 * K - 1 : K, k1 = L.coarsen[2] ? 2 * K : K;
      for (int k = k0; k <= k1; ++k)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) {
            const int I = L.coarsen[0] ? (i + 1) / 2 : i, J = L.coarsen[1] ? (j + 1) / 2 : j;
            const std::ptrdiff_t n = s(i, j, k), nc = cs(I, J, K);
            for (int q = 0; q < M; ++q) C.b[std::size_t(nc * M + q)] += L.r[std::size_t(n * M + q)];
          }
    }
    vcycle<M>(l + 1);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          if (!L.active(n)) continue;
          const int I = L.coarsen[0] ? (i + 1) / 2 : i, J = L.coarsen[1] ? (j + 1) / 2 : j,
                    K = L.coarsen[2] ? (k + 1) / 2 : k;
          const std::ptrdiff_t nc = cs(I, J, K);
          for (int q = 0; q < M; ++q) L.x[std::size_t(n * M + q)] += C.x[std::size_t(nc * M + q)];
        }
    block_smooth<M>(L, smoothing, 1, omega);
  }

  template <int M>
  void solve_block(const std::vector<Field*>& xs, const std::vector<const Field*>& bs, double rtol, int max_iterations,
                   LaplaceStats* stats) const;
};

// Loops over the active cells plane by plane (k outermost, in parallel) and, inside a plane, over the m right-hand
// sides: a plane's conductances are read from memory once and from cache for the other m - 1.
template <class F>
void for_planes(const Shape& s, F&& body) {
#pragma omp parallel for schedule(static) if (ns::threaded(s))
  for (int k = 1; k <= s.nz; ++k) body(k);
}

template <int M>
void NeumannLaplacian::Impl::solve_block(const std::vector<Field*>& xs, const std::vector<const Field*>& bs,
                                         double rtol, int max_iterations, LaplaceStats* stats) const {
  const Level& L = *fine;
  const Shape& s = L.s;
  const double* dg = L.diag.data();
  const double *a0 = L.a[0].data(), *a1 = L.a[1].data(), *a2 = L.a[2].data();
  const std::ptrdiff_t sy = s.sy, sz = s.sz;
  if (work.size() < std::size_t(M)) work.resize(std::size_t(M));
  for (int q = 0; q < M; ++q)
    for (Field& f : work[std::size_t(q)])
      if (!(f.shape() == s)) f = Field(s);
  for (const BlockLevel& l : levels) l.reserve(M);
  double *X[M], *R[M], *P[M], *Q[M], *B[M];
  for (int q = 0; q < M; ++q) {
    X[q] = xs[std::size_t(q)]->data();
    auto& w = work[std::size_t(q)];
    R[q] = w[0].data(), P[q] = w[1].data(), Q[q] = w[2].data(), B[q] = w[3].data();
  }
  // b without its mean over the active cells (the compatible part), x zero where inactive.
  std::array<double, M> sum{};
  std::size_t count = 0;
  {
    double* sp = sum.data();
#pragma omp parallel for schedule(static) reduction(+ : sp[:M], count) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          if (!(dg[n] > 0)) continue;
          ++count;
          for (int q = 0; q < M; ++q) sp[q] += (*bs[std::size_t(q)])[n];
        }
  }
  for_planes(s, [&](int k) {
    for (int q = 0; q < M; ++q) {
      const double* bin = bs[std::size_t(q)]->data();
      const double mean = count > 0 ? sum[std::size_t(q)] / double(count) : 0.0;
      for (int j = 0; j <= s.ny + 1; ++j)
        for (int i = 0; i <= s.nx + 1; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          const bool on = dg[n] > 0;
          B[q][n] = on ? bin[n] - mean : 0.0;
          if (!on) X[q][n] = 0;
        }
    }
  });
  for (int q = 0; q < M; ++q)  // the ghost planes (read with zero conductance across the domain's faces)
    for (const int k : {0, s.nz + 1})
      for (int j = 0; j <= s.ny + 1; ++j)
        for (int i = 0; i <= s.nx + 1; ++i) X[q][s(i, j, k)] = B[q][s(i, j, k)] = 0;
  // out_q = b_q - A x_q (b null: A x_q) for every q; with dot, also sum over the cells of p_q . out_q.
  // Potentials marked in skip (converged) are left alone.
  const auto apply = [&](double* const* x, double* const* b, double* const* out, double* dot, const bool* skip) {
    for (int q = 0; q < M; ++q)
      if (!skip[q]) fill_ghosts(s, L.periodic, x[q]);
    std::array<double, M> acc{};
    double* ap = acc.data();
#pragma omp parallel for schedule(static) reduction(+ : ap[:M]) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int q = 0; q < M; ++q) {
        if (skip[q]) continue;
        const double* xq = x[q];
        double* oq = out[q];
        const double* bq = b ? b[q] : nullptr;
        double local = 0;
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) {
            const std::ptrdiff_t n = s(i, j, k);
            const double ax = dg[n] * xq[n] - (a0[n] * xq[n - 1] + a0[n + 1] * xq[n + 1] + a1[n] * xq[n - sy] +
                                                a1[n + sy] * xq[n + sy] + a2[n] * xq[n - sz] + a2[n + sz] * xq[n + sz]);
            const double v = dg[n] > 0 ? (bq ? bq[n] - ax : ax) : 0.0;
            oq[n] = v;
            local += xq[n] * v;
          }
        ap[q] += local;
      }
    if (dot)
      for (int q = 0; q < M; ++q) dot[q] = acc[std::size_t(q)];
  };
  const auto max_abs = [&](double* const* f) {
    std::array<double, M> m{};
    double* mp = m.data();
#pragma omp parallel for schedule(static) reduction(max : mp[:M]) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int q = 0; q < M; ++q)
        for (int j = 1; j <= s.ny; ++j)
          for (int i = 1; i <= s.nx; ++i) {
            const std::ptrdiff_t n = s(i, j, k);
            if (dg[n] > 0) mp[q] = std::max(mp[q], std::abs(f[q][n]));
          }
    return m;
  };
  // z = M r: one V-cycle on the residuals in the interleaved float right-hand side V.b (written where r is updated),
  // z read from V.x.
  const BlockLevel& V = levels[0];
  float* vb = V.b.data();
  const float* z = V.x.data();
  const std::array<bool, M> none{};
  apply(X, B, R, nullptr, none.data());
  std::array<double, M> bnorm = max_abs(B), res = max_abs(R), target{};
  std::array<bool, M> done{};
  bool all = true;
  for (int q = 0; q < M; ++q) {
    stats[q] = LaplaceStats{};
    stats[q].initial_residual = stats[q].residual = res[q];
    target[q] = rtol * bnorm[q];
    done[q] = bnorm[q] == 0 || res[q] <= target[q];
    stats[q].converged = done[q];
    all = all && done[q];
  }
  if (!all) {
    for_planes(s, [&](int k) {
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          for (int q = 0; q < M; ++q) vb[n * M + q] = float(R[q][n]);
        }
    });
    vcycle<M>(0);
    std::array<double, M> rz{};
    {
      double* rp = rz.data();
#pragma omp parallel for schedule(static) reduction(+ : rp[:M]) if (ns::threaded(s))
      for (int k = 1; k <= s.nz; ++k)
        for (int q = 0; q < M; ++q)
          for (int j = 1; j <= s.ny; ++j)
            for (int i = 1; i <= s.nx; ++i) {
              const std::ptrdiff_t n = s(i, j, k);
              const bool on = dg[n] > 0;
              P[q][n] = on ? double(z[n * M + q]) : 0.0;
              if (on) rp[q] += R[q][n] * double(z[n * M + q]);
            }
    }
    for (int it = 1; it <= max_iterations; ++it) {
      std::array<double, M> pq{}, alpha{};
      apply(P, nullptr, Q, pq.data(), done.data());
      for (int q = 0; q < M; ++q) {
        if (!done[q] && !(pq[q] > 0)) done[q] = true;  // breakdown: stop this one, not converged
        alpha[q] = done[q] ? 0.0 : rz[q] / pq[q];
      }
      {
        double* mp = res.data();
        for (int q = 0; q < M; ++q) mp[q] = 0;
#pragma omp parallel for schedule(static) reduction(max : mp[:M]) if (ns::threaded(s))
        for (int k = 1; k <= s.nz; ++k)
          for (int q = 0; q < M; ++q) {
            if (alpha[q] == 0) continue;
            double local = 0;
            for (int j = 1; j <= s.ny; ++j)
              for (int i = 1; i <= s.nx; ++i) {
                const std::ptrdiff_t n = s(i, j, k);
                X[q][n] += alpha[q] * P[q][n];
                R[q][n] -= alpha[q] * Q[q][n];
                vb[n * M + q] = float(R[q][n]);
                local = std::max(local, std::abs(R[q][n]));
              }
            mp[q] = std::max(mp[q], local);
          }
      }
      all = true;
      for (int q = 0; q < M; ++q) {
        if (!done[q]) {
          stats[q].iterations = it;
          stats[q].residual = res[q];
          if (res[q] <= target[q]) done[q] = stats[q].converged = true;
        }
        all = all && done[q];
      }
      if (all) break;
      vcycle<M>(0);
      // flexible (Polak-Ribiere) beta: the coarsest level is relaxed to a tolerance, so M varies slightly;
      // z . (r - r_old) = -alpha z . q (the residual changed by -alpha q), so no copy of the old residual is kept
      std::array<double, M> num{}, rzn{};
      {
        double *np = num.data(), *rp = rzn.data();
#pragma omp parallel for schedule(static) reduction(+ : np[:M], rp[:M]) if (ns::threaded(s))
        for (int k = 1; k <= s.nz; ++k)
          for (int q = 0; q < M; ++q) {
            if (done[q]) continue;
            for (int j = 1; j <= s.ny; ++j)
              for (int i = 1; i <= s.nx; ++i) {
                const std::ptrdiff_t n = s(i, j, k);
                if (!(dg[n] > 0)) continue;
                const double zn = z[n * M + q];
                np[q] -= alpha[q] * zn * Q[q][n];
                rp[q] += R[q][n] * zn;
              }
          }
      }
      std::array<double, M> beta{};
      for (int q = 0; q < M; ++q) {
        beta[q] = done[q] ? 0.0 : num[q] / rz[q];
        rz[q] = rzn[q];
      }
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (int k = 1; k <= s.nz; ++k)
        for (int q = 0; q < M; ++q) {
          if (done[q]) continue;
          for (int j = 1; j <= s.ny; ++j)
            for (int i = 1; i <= s.nx; ++i) {
              const std::ptrdiff_t n = s(i, j, k);
              P[q][n] = dg[n] > 0 ? double(z[n * M + q]) + beta[q] * P[q][n] : 0.0;
            }
        }
    }
  }
  for (int q = 0; q < M; ++q) fill_ghosts(s, L.periodic, X[q]);
}

NeumannLaplacian::NeumannLaplacian(const Grid& g, const FluidGeometry& geo) : impl_(std::make_unique<Impl>()) {
  if (!(geo.shape == g.shape())) throw std::invalid_argument("force partitioning: a fluid geometry of another grid");
  for (int d = 0; d < 3; ++d)
    if (g.axis[std::size_t(d)].periodic && g.axis[std::size_t(d)].n % 2 != 0)
      throw std::invalid_argument("force partitioning: a periodic axis needs an even number of cells (axis " +
                                  std::to_string(d) + " has " + std::to_string(g.axis[std::size_t(d)].n) + ")");
  std::vector<Level> levels;
  levels.emplace_back(g.axis);
  {
    Level& L = levels.back();
    const Shape& s = L.s;
    for (int d = 0; d < 3; ++d) {
      const Axis& ad = g.axis[std::size_t(d)];
      const int e = (d + 1) % 3, f = (d + 2) % 3;
#pragma omp parallel for schedule(static) if (ns::threaded(s))
      for (int k = 1; k <= s.nz + (d == 2); ++k)
        for (int j = 1; j <= s.ny + (d == 1); ++j)
          for (int i = 1; i <= s.nx + (d == 0); ++i) {
            const int I[3] = {i, j, k};
            if (I[e] > s.n(e) || I[f] > s.n(f)) continue;
            const int F = I[d];
            if (!ad.periodic && (F == 1 || F == s.n(d) + 1)) continue;  // the domain's faces: no flux
            if (ad.periodic && F == s.n(d) + 1) continue;                 // the image of face 1 (finish())
            const double beta = geo.aperture[std::size_t(d)](i, j, k);
            if (beta <= 0) continue;
            const double area = g.axis[std::size_t(e)].dc[std::size_t(I[e])] * g.axis[std::size_t(f)].dc[std::size_t(I[f])];
            L.a[d](i, j, k) = beta * area / ad.df[std::size_t(F)];
          }
    }
    L.finish();
  }
  // Coarser levels: halve every axis that has an even number (>= 4) of cells, while the level has more than 64.
  while (true) {
    const Level& F = levels.back();
    if (F.s.cells() <= 64) break;
    bool any = false;
    std::array<Axis, 3> ax = F.axis;
    bool co[3];
    for (int d = 0; d < 3; ++d) {
      co[d] = F.s.n(d) % 2 == 0 && F.s.n(d) >= 4;
      if (co[d]) ax[std::size_t(d)] = F.axis[std::size_t(d)].coarsened();
      any = any || co[d];
    }
    if (!any) break;
    for (int d = 0; d < 3; ++d) levels.back().coarsen[d] = co[d];
    Level C(std::move(ax));
    const Level& Fl = levels.back();
    const Shape& cs = C.s;
    for (int d = 0; d < 3; ++d) {
      const int e = (d + 1) % 3, f = (d + 2) % 3;
#pragma omp parallel for schedule(static) if (ns::threaded(cs))
      for (int K = 1; K <= cs.nz + (d == 2); ++K)
        for (int J = 1; J <= cs.ny + (d == 1); ++J)
          for (int I = 1; I <= cs.nx + (d == 0); ++I) {
            const int X[3] = {I, J, K};
            if (X[e] > cs.n(e) || X[f] > cs.n(f)) continue;
            const int fd = co[d] ? 2 * X[d] - 1 : X[d];
            const int e0 = co[e] ? 2 * X[e] - 1 : X[e], e1 = co[e] ? 2 * X[e] : X[e];
            const int f0 = co[f] ? 2 * X[f] - 1 : X[f], f1 = co[f] ? 2 * X[f] : X[f];
            double sum = 0;
            for (int ye = e0; ye <= e1; ++ye)
              for (int yf = f0; yf <= f1; ++yf) {
                int Y[3];
                Y[d] = fd;
                Y[e] = ye;
                Y[f] = yf;
                sum += Fl.a[d](Y[0], Y[1], Y[2]);
              }
            C.a[d](I, J, K) = sum * Fl.axis[std::size_t(d)].df[std::size_t(fd)] / C.axis[std::size_t(d)].df[std::size_t(X[d])];
          }
    }
    C.finish();
    levels.push_back(std::move(C));
  }
  for (const Level& l : levels) impl_->levels.emplace_back(l);
  impl_->fine.emplace(std::move(levels[0]));
}

NeumannLaplacian::~NeumannLaplacian() = default;
NeumannLaplacian::NeumannLaplacian(NeumannLaplacian&&) noexcept = default;
NeumannLaplacian& NeumannLaplacian::operator=(NeumannLaplacian&&) noexcept = default;

int NeumannLaplacian::levels() const { return int(impl_->levels.size()); }

double NeumannLaplacian::conductance(int d, int i, int j, int k) const { return impl_->fine->a[d](i, j, k); }
bool NeumannLaplacian::active(int i, int j, int k) const {
  const Level& L = *impl_->fine;
  return L.active(L.s(i, j, k));
}

std::size_t NeumannLaplacian::bytes() const {
  const Impl& m = *impl_;
  std::size_t b = 4 * m.fine->s.size() * sizeof(double);  // the double operator: a[3], diag
  for (const BlockLevel& L : m.levels) b += (4 * L.s.size() + L.x.size() + L.b.size() + L.r.size()) * sizeof(float);
  return b + 4 * m.work.size() * m.fine->s.size() * sizeof(double);
}

void NeumannLaplacian::take_workspace(NeumannLaplacian& previous) {
  if (!previous.impl_ || !(previous.impl_->fine->s == impl_->fine->s)) return;
  impl_->work = std::move(previous.impl_->work);
  for (std::size_t l = 0; l < std::min(impl_->levels.size(), previous.impl_->levels.size()); ++l) {
    BlockLevel &to = impl_->levels[l], &from = previous.impl_->levels[l];
    if (!(to.s == from.s)) break;
    to.x = std::move(from.x), to.b = std::move(from.b), to.r = std::move(from.r);
  }
}

void NeumannLaplacian::apply(Field& x, Field& Ax) const { impl_->fine->apply(x, Ax); }

LaplaceStats NeumannLaplacian::solve(Field& x, const Field& b, double rtol, int max_iterations) const {
  return solve({&x}, {&b}, rtol, max_iterations).front();
}

std::vector<LaplaceStats> NeumannLaplacian::solve(const std::vector<Field*>& xs, const std::vector<const Field*>& bs,
                                                  double rtol, int max_iterations) const {
  if (xs.size() != bs.size()) throw std::invalid_argument("force partitioning: as many solutions as right-hand sides");
  std::vector<LaplaceStats> stats(xs.size());
  for (std::size_t first = 0; first < xs.size(); first += max_block) {
    const std::size_t m = std::min(max_block, xs.size() - first);
    const std::vector<Field*> x(xs.begin() + std::ptrdiff_t(first), xs.begin() + std::ptrdiff_t(first + m));
    const std::vector<const Field*> b(bs.begin() + std::ptrdiff_t(first), bs.begin() + std::ptrdiff_t(first + m));
    LaplaceStats* st = stats.data() + first;
    const Impl& I = *impl_;
    switch (m) {
      case 1: I.solve_block<1>(x, b, rtol, max_iterations, st); break;
      case 2: I.solve_block<2>(x, b, rtol, max_iterations, st); break;
      case 3: I.solve_block<3>(x, b, rtol, max_iterations, st); break;
      case 4: I.solve_block<4>(x, b, rtol, max_iterations, st); break;
      case 5: I.solve_block<5>(x, b, rtol, max_iterations, st); break;
      case 6: I.solve_block<6>(x, b, rtol, max_iterations, st); break;
      case 7: I.solve_block<7>(x, b, rtol, max_iterations, st); break;
      default: I.solve_block<8>(x, b, rtol, max_iterations, st); break;
    }
  }
  return stats;
}

}  // namespace flapstab::fpm
