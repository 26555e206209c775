// Neumann Laplace problems on the fluid cells (laplace.hpp).
#include "cfd/fpm/laplace.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace flapstab::fpm {

namespace {

using ns::Axis;
using ns::real;

bool periodic_of(const std::array<Axis, 3>& ax, int d) { return ax[std::size_t(d)].periodic; }

void fill_ghosts(const Shape& s, const bool periodic[3], real* x) {
  for (int a = 0; a < 3; ++a) {
    if (!periodic[a]) continue;
    const int b = (a + 1) % 3, c = (a + 2) % 3, n = s.n(a);
    const std::ptrdiff_t sa = s.stride(a), sb = s.stride(b), sc = s.stride(c);
    for (int kc = 0; kc <= s.n(c) + 1; ++kc)
      for (int kb = 0; kb <= s.n(b) + 1; ++kb) {
        real* l = x + kb * sb + kc * sc;
        l[0] = l[n * sa];
        l[(n + 1) * sa] = l[sa];
      }
  }
}

struct Level {
  std::array<Axis, 3> axis;
  Shape s;
  bool periodic[3] = {false, false, false};
  bool coarsen[3] = {false, false, false};  // coarsened by 2 towards the next level
  Field a[3], diag;
  mutable Field x, b, r;  // work: correction, right-hand side, residual

  explicit Level(std::array<Axis, 3> ax) : axis(std::move(ax)), s(axis[0].n, axis[1].n, axis[2].n) {
    for (int d = 0; d < 3; ++d) {
      periodic[d] = periodic_of(axis, d);
      a[d] = Field(s);
    }
    diag = Field(s);
    x = Field(s);
    b = Field(s);
    r = Field(s);
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
  void residual(Field& xv, const Field& bv, Field& rv) const { apply_or_residual(xv, &bv, rv); }

  // Red-black Gauss-Seidel: colours in the given order, `sweeps` times.
  void smooth(Field& xv, const Field& bv, int sweeps, int first_colour) const {
    for (int sw = 0; sw < sweeps; ++sw)
      for (int c = 0; c < 2; ++c) {
        const int colour = (first_colour + c) % 2;
        fill_ghosts(s, periodic, xv.data());
        real* xp = xv.data();
#pragma omp parallel for schedule(static) if (ns::threaded(s))
        for (int k = 1; k <= s.nz; ++k)
          for (int j = 1; j <= s.ny; ++j)
            for (int i = 1 + ((j + k + 1 + colour) % 2); i <= s.nx; i += 2) {
              const std::ptrdiff_t n = s(i, j, k);
              if (active(n)) xp[n] = (bv[n] + off(xp, i, j, k)) / diag[n];
            }
      }
  }
};

double max_abs_active(const Level& L, const Field& f) {
  double m = 0;
  const Shape& s = L.s;
#pragma omp parallel for schedule(static) reduction(max : m) if (ns::threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const std::ptrdiff_t n = s(i, j, k);
        if (L.active(n)) m = std::max(m, std::abs(f[n]));
      }
  return m;
}

double dot_active(const Level& L, const Field& f, const Field& g) {
  double sum = 0;
  const Shape& s = L.s;
#pragma omp parallel for schedule(static) reduction(+ : sum) if (ns::threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const std::ptrdiff_t n = s(i, j, k);
        if (L.active(n)) sum += f[n] * g[n];
      }
  return sum;
}

}  // namespace

void fill_periodic_ghosts(const Grid& g, Field& x) {
  const bool p[3] = {g.axis[0].periodic, g.axis[1].periodic, g.axis[2].periodic};
  fill_ghosts(x.shape(), p, x.data());
}

struct NeumannLaplacian::Impl {
  std::vector<Level> levels;
  mutable Field r, z, p, q, rhs;

  // V-cycle on level l: L.x from zero for the right-hand side L.b.
  void vcycle(std::size_t l) const {
    const Level& L = levels[l];
    L.x.fill(0);
    if (l + 1 == levels.size()) {
      // Coarsest level: symmetric sweeps until the residual falls a hundredfold (or 400 sweeps).
      L.residual(L.x, L.b, L.r);
      const double r0 = max_abs_active(L, L.r);
      for (int it = 0; it < 200 && r0 > 0; ++it) {
        L.smooth(L.x, L.b, 1, 0);
        L.smooth(L.x, L.b, 1, 1);
        if (it % 10 == 9) {
          L.residual(L.x, L.b, L.r);
          if (max_abs_active(L, L.r) <= 1e-2 * r0) break;
        }
      }
      return;
    }
    L.smooth(L.x, L.b, 2, 0);
    L.residual(L.x, L.b, L.r);
    const Level& C = levels[l + 1];
    C.b.fill(0);
    const Shape& s = L.s;
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const int I = L.coarsen[0] ? (i + 1) / 2 : i, J = L.coarsen[1] ? (j + 1) / 2 : j,
                    K = L.coarsen[2] ? (k + 1) / 2 : k;
          C.b(I, J, K) += L.r(i, j, k);
        }
    vcycle(l + 1);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          if (!L.active(n)) continue;
          const int I = L.coarsen[0] ? (i + 1) / 2 : i, J = L.coarsen[1] ? (j + 1) / 2 : j,
                    K = L.coarsen[2] ? (k + 1) / 2 : k;
          L.x[n] += C.x(I, J, K);
        }
    L.smooth(L.x, L.b, 2, 1);
  }

  // z = M r (one V-cycle from zero).
  void precondition(const Field& rin, Field& zout) const {
    const Level& L = levels[0];
    std::copy(rin.begin(), rin.end(), L.b.begin());
    vcycle(0);
    std::copy(L.x.begin(), L.x.end(), zout.begin());
  }
};

NeumannLaplacian::NeumannLaplacian(const Grid& g, const FluidGeometry& geo) : impl_(std::make_unique<Impl>()) {
  if (!(geo.shape == g.shape())) throw std::invalid_argument("force partitioning: a fluid geometry of another grid");
  for (int d = 0; d < 3; ++d)
    if (g.axis[std::size_t(d)].periodic && g.axis[std::size_t(d)].n % 2 != 0)
      throw std::invalid_argument("force partitioning: a periodic axis needs an even number of cells (axis " +
                                  std::to_string(d) + " has " + std::to_string(g.axis[std::size_t(d)].n) + ")");
  auto& levels = impl_->levels;
  levels.emplace_back(g.axis);
  {
    Level& L = levels.back();
    const Shape& s = L.s;
    for (int d = 0; d < 3; ++d) {
      const Axis& ad = g.axis[std::size_t(d)];
      const int e = (d + 1) % 3, f = (d + 2) % 3;
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
  const Shape s = levels[0].s;
  for (Field* f : {&impl_->r, &impl_->z, &impl_->p, &impl_->q, &impl_->rhs}) *f = Field(s);
}

NeumannLaplacian::~NeumannLaplacian() = default;
NeumannLaplacian::NeumannLaplacian(NeumannLaplacian&&) noexcept = default;
NeumannLaplacian& NeumannLaplacian::operator=(NeumannLaplacian&&) noexcept = default;

int NeumannLaplacian::levels() const { return int(impl_->levels.size()); }

double NeumannLaplacian::conductance(int d, int i, int j, int k) const { return impl_->levels[0].a[d](i, j, k); }
bool NeumannLaplacian::active(int i, int j, int k) const {
  const Level& L = impl_->levels[0];
  return L.active(L.s(i, j, k));
}

std::size_t NeumannLaplacian::bytes() const {
  std::size_t b = 0;
  for (const Level& L : impl_->levels) b += 8 * L.s.size() * sizeof(double);
  return b + 5 * impl_->levels[0].s.size() * sizeof(double);  // r, z, p, q, rhs
}

void NeumannLaplacian::apply(Field& x, Field& Ax) const { impl_->levels[0].apply(x, Ax); }

LaplaceStats NeumannLaplacian::solve(Field& x, const Field& bin, double rtol, int max_iterations) const {
  Impl& m = *impl_;
  const Level& L = m.levels[0];
  const Shape& s = L.s;
  LaplaceStats st;
  // b without its mean over the active cells (the compatible part), x zero where inactive
  m.rhs = bin;  // the work array's storage is reused from call to call
  Field& b = m.rhs;
  double sum = 0;
  std::size_t count = 0;
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const std::ptrdiff_t n = s(i, j, k);
        if (L.active(n)) {
          sum += b[n];
          ++count;
        } else {
          b[n] = 0;
          x[n] = 0;
        }
      }
  if (count > 0)
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          if (L.active(n)) b[n] -= sum / double(count);
        }
  const double bnorm = max_abs_active(L, b);
  L.residual(x, b, m.r);
  st.initial_residual = st.residual = max_abs_active(L, m.r);
  const double target = rtol * bnorm;
  if (bnorm == 0 || st.residual <= target) {
    st.converged = true;
    return st;
  }
  m.precondition(m.r, m.z);
  m.p = m.z;
  double rz = dot_active(L, m.r, m.z);
  for (int it = 1; it <= max_iterations; ++it) {
    L.apply(m.p, m.q);
    const double pq = dot_active(L, m.p, m.q);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          if (!L.active(n)) continue;
          x[n] += alpha * m.p[n];
          m.r[n] -= alpha * m.q[n];
        }
    st.iterations = it;
    st.residual = max_abs_active(L, m.r);
    if (st.residual <= target) {
      st.converged = true;
      break;
    }
    m.precondition(m.r, m.z);
    // flexible (Polak-Ribiere) beta: the coarsest level is relaxed to a tolerance, so M varies slightly;
    // z . (r - r_old) = -alpha z . q (the residual changed by -alpha q), so no copy of the old residual is kept
    double num = 0;
#pragma omp parallel for schedule(static) reduction(+ : num) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          if (L.active(n)) num -= alpha * m.z[n] * m.q[n];
        }
    const double beta = num / rz;
    rz = dot_active(L, m.r, m.z);
#pragma omp parallel for schedule(static) if (ns::threaded(s))
    for (int k = 1; k <= s.nz; ++k)
      for (int j = 1; j <= s.ny; ++j)
        for (int i = 1; i <= s.nx; ++i) {
          const std::ptrdiff_t n = s(i, j, k);
          m.p[n] = L.active(n) ? m.z[n] + beta * m.p[n] : 0;
        }
  }
  fill_ghosts(s, L.periodic, x.data());
  return st;
}

}  // namespace flapstab::fpm
