// Vector kernels of the conjugate-gradient solvers on padded cell fields, in the volume-weighted inner product
// <u, w> = sum over cells of V u w (in which the MAC Laplacian is self-adjoint). Each kernel works on one plane k
// (vectorised, compiled for AVX-512/AVX2/baseline); the drivers run them over the planes with OpenMP.
#pragma once
#include <omp.h>
#include <algorithm>
#include <cmath>
#include "cfd/navier_stokes/stencil.hpp"

namespace flapstab::ns::krylov {

template <class T>
int threads(const Stencil<T>& L) {
  return threaded(L.s) ? std::max(1, std::min(omp_get_max_threads(), L.s.nz)) : 1;
}

namespace plane {

template <class T>
FLAPSTAB_KERNEL double inner(const Stencil<T>& L, int k, const T* u, const T* w) {
  const Shape& s = L.s;
  const T* __restrict vx = L.vol[0].data();
  double sum = 0;
  for (int j = 1; j <= s.ny; ++j) {
    const T* __restrict ur = u + s(0, j, k);
    const T* __restrict wr = w + s(0, j, k);
    double row = 0;
#pragma omp simd reduction(+ : row)
    for (int i = 1; i <= s.nx; ++i) row += double(vx[i] * ur[i] * wr[i]);
    sum += double(L.vol[1][j]) * row;
  }
  return double(L.vol[2][k]) * sum;
}

template <class T>
FLAPSTAB_KERNEL void axpy_into(const Stencil<T>& L, int k, const T* z, T beta, T* p) {
  const Shape& s = L.s;
  for (int j = 1; j <= s.ny; ++j) {
    const T* __restrict zr = z + s(0, j, k);
    T* __restrict pr = p + s(0, j, k);
#pragma omp simd
    for (int i = 1; i <= s.nx; ++i) pr[i] = zr[i] + beta * pr[i];
  }
}

template <class T>
FLAPSTAB_KERNEL void apply_and_dot(const Stencil<T>& L, int k, const T* p, T* q, const T* r, double& pq, double& pr) {
  const Shape& s = L.s;
  const T* __restrict vx = L.vol[0].data();
  double a = 0, c = 0;
  for (int j = 1; j <= s.ny; ++j) {
    const StencilRow<T> row(L, p, j, k);
    const T* __restrict pp = p + s(0, j, k);
    const T* __restrict rr = r + s(0, j, k);
    T* __restrict qr = q + s(0, j, k);
    double ra = 0, rc = 0;
#pragma omp simd reduction(+ : ra, rc)
    for (int i = 1; i <= s.nx; ++i) {
      const T v = row.apply(i);
      qr[i] = v;
      ra += double(vx[i] * pp[i] * v);
      rc += double(vx[i] * pp[i] * rr[i]);
    }
    a += double(L.vol[1][j]) * ra;
    c += double(L.vol[1][j]) * rc;
  }
  pq = double(L.vol[2][k]) * a;
  pr = double(L.vol[2][k]) * c;
}

template <class T>
FLAPSTAB_KERNEL double update(const Stencil<T>& L, int k, T* x, T* r, const T* p, const T* q, T alpha, bool first) {
  const Shape& s = L.s;
  double m = 0;
  for (int j = 1; j <= s.ny; ++j) {
    const std::ptrdiff_t o = s(0, j, k);
    T* __restrict xr = x + o;
    T* __restrict rr = r + o;
    const T* __restrict pr = p + o;
    const T* __restrict qr = q + o;
    if (first) {
#pragma omp simd
      for (int i = 1; i <= s.nx; ++i) xr[i] = alpha * pr[i];
    } else {
#pragma omp simd
      for (int i = 1; i <= s.nx; ++i) xr[i] += alpha * pr[i];
    }
    double row = 0;
#pragma omp simd reduction(max : row)
    for (int i = 1; i <= s.nx; ++i) {
      rr[i] -= alpha * qr[i];
      row = std::max(row, double(std::abs(rr[i])));
    }
    m = std::max(m, row);
  }
  return m;
}

// x += z (x = z if first), r -= L z; returns max |r| of the plane.
template <class T>
FLAPSTAB_KERNEL double correct(const Stencil<T>& L, int k, T* x, T* r, const T* z, bool first) {
  const Shape& s = L.s;
  double m = 0;
  for (int j = 1; j <= s.ny; ++j) {
    const StencilRow<T> row(L, z, j, k);
    const std::ptrdiff_t o = s(0, j, k);
    T* __restrict xr = x + o;
    T* __restrict rr = r + o;
    const T* __restrict zr = z + o;
    double rm = 0;
#pragma omp simd reduction(max : rm)
    for (int i = 1; i <= s.nx; ++i) {
      xr[i] = first ? zr[i] : xr[i] + zr[i];
      rr[i] -= row.apply(i);
      rm = std::max(rm, double(std::abs(rr[i])));
    }
    m = std::max(m, rm);
  }
  return m;
}

template <class T>
FLAPSTAB_KERNEL double residual(const Stencil<T>& L, int k, const T* x, T* r) {
  const Shape& s = L.s;
  double m = 0;
  for (int j = 1; j <= s.ny; ++j) {
    const StencilRow<T> row(L, x, j, k);
    T* __restrict rr = r + s(0, j, k);
    double rm = 0;
#pragma omp simd reduction(max : rm)
    for (int i = 1; i <= s.nx; ++i) {
      rr[i] -= row.apply(i);
      rm = std::max(rm, double(std::abs(rr[i])));
    }
    m = std::max(m, rm);
  }
  return m;
}

template <class T>
FLAPSTAB_KERNEL void sum_and_max(const Stencil<T>& L, int k, const T* f, double& sum, double& vol, double& max) {
  const Shape& s = L.s;
  const T* __restrict vx = L.vol[0].data();
  double su = 0, vo = 0, mx = 0;
  for (int j = 1; j <= s.ny; ++j) {
    const T* __restrict fr = f + s(0, j, k);
    double rs = 0, rv = 0, rm = 0;
#pragma omp simd reduction(+ : rs, rv) reduction(max : rm)
    for (int i = 1; i <= s.nx; ++i) {
      rs += double(vx[i] * fr[i]);
      rv += double(vx[i]);
      rm = std::max(rm, double(std::abs(fr[i])));
    }
    su += double(L.vol[1][j]) * rs;
    vo += double(L.vol[1][j]) * rv;
    mx = std::max(mx, rm);
  }
  sum = double(L.vol[2][k]) * su;
  vol = double(L.vol[2][k]) * vo;
  max = mx;
}

}  // namespace plane

// <u, w>
template <class T>
double inner(const Stencil<T>& L, const T* u, const T* w) {
  double sum = 0;
#pragma omp parallel for schedule(static) reduction(+ : sum) num_threads(threads(L))
  for (int k = 1; k <= L.s.nz; ++k) sum += plane::inner(L, k, u, w);
  return sum;
}

// p = z + beta p
template <class T>
void axpy_into(const Stencil<T>& L, const T* z, T beta, T* p) {
#pragma omp parallel for schedule(static) num_threads(threads(L))
  for (int k = 1; k <= L.s.nz; ++k) plane::axpy_into(L, k, z, beta, p);
}

// q = L p (p's ghosts hold the boundary conditions), with <p, q> and <p, r>.
template <class T>
void apply_and_dot(const Stencil<T>& L, const T* p, T* q, const T* r, double& pq, double& pr) {
  double a = 0, c = 0;
#pragma omp parallel for schedule(static) reduction(+ : a, c) num_threads(threads(L))
  for (int k = 1; k <= L.s.nz; ++k) {
    double ak, ck;
    plane::apply_and_dot(L, k, p, q, r, ak, ck);
    a += ak;
    c += ck;
  }
  pq = a;
  pr = c;
}

// x += alpha p (x = alpha p if first), r -= alpha q; returns max |r|.
template <class T>
double update(const Stencil<T>& L, T* x, T* r, const T* p, const T* q, T alpha, bool first) {
  double m = 0;
#pragma omp parallel for schedule(static) reduction(max : m) num_threads(threads(L))
  for (int k = 1; k <= L.s.nz; ++k) m = std::max(m, plane::update(L, k, x, r, p, q, alpha, first));
  return m;
}

// x += z (x = z if first), r -= L z (z's ghosts hold the boundary conditions); returns max |r|.
template <class T>
double correct(const Stencil<T>& L, T* x, T* r, const T* z, bool first) {
  double m = 0;
#pragma omp parallel for schedule(static) reduction(max : m) num_threads(threads(L))
  for (int k = 1; k <= L.s.nz; ++k) m = std::max(m, plane::correct(L, k, x, r, z, first));
  return m;
}

// r -= L x (x's ghosts hold the boundary conditions); returns max |r|.
template <class T>
double residual(const Stencil<T>& L, const T* x, T* r) {
  double m = 0;
#pragma omp parallel for schedule(static) reduction(max : m) num_threads(threads(L))
  for (int k = 1; k <= L.s.nz; ++k) m = std::max(m, plane::residual(L, k, x, r));
  return m;
}

// Volume-weighted sum, volume and max-norm of a cell field.
template <class T>
void sum_and_max(const Stencil<T>& L, const T* f, double& sum, double& volume, double& max) {
  double su = 0, vo = 0, mx = 0;
#pragma omp parallel for schedule(static) reduction(+ : su, vo) reduction(max : mx) num_threads(threads(L))
  for (int k = 1; k <= L.s.nz; ++k) {
    double a, b, c;
    plane::sum_and_max(L, k, f, a, b, c);
    su += a;
    vo += b;
    mx = std::max(mx, c);
  }
  sum = su;
  volume = vo;
  max = mx;
}

template <class T>
void add_constant(const Stencil<T>& L, T* f, T c) {
  const Shape& s = L.s;
#pragma omp parallel for schedule(static) num_threads(threads(L))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) f[s(i, j, k)] += c;
}

}  // namespace flapstab::ns::krylov
