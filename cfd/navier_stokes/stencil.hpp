// The MAC Laplacian L = D G on a grid with box conditions, as per-direction coefficients (shared by the Krylov
// solver in double and the multigrid preconditioner in single precision).
#pragma once
#include <array>
#include <vector>
#include "cfd/navier_stokes/boundary.hpp"
#include "cfd/navier_stokes/grid.hpp"

namespace flapstab::ns {

// (L x)_I = sum over axes a of cl_a x[I-1] + ch_a x[I+1] + dg_a x[I]: the flux differences of the MAC gradient
// (x[I] - x[I-1]) / df[I] across the faces of cell I, divided by its width dc[I]. A Neumann face has no flux; a
// Dirichlet face (x = 0 on it) has the flux of the mirrored ghost -x, so its coefficient moves to the diagonal.
template <class T>
struct Stencil {
  Shape s;
  bool periodic[3];
  std::array<std::vector<T>, 3> cl, ch, dg, vol;  // vol: cell widths (volume = product)

  Stencil(const Grid& g, const ScalarBCs& bc) : s(g.shape()) {
    for (int a = 0; a < 3; ++a) {
      const Axis& ax = g.axis[a];
      const int n = ax.n;
      periodic[a] = ax.periodic;
      cl[a].assign(n + 2, 0);
      ch[a].assign(n + 2, 0);
      dg[a].assign(n + 2, 0);
      vol[a].assign(ax.dc.begin(), ax.dc.end());
      std::vector<double> lo(n + 2, 0), hi(n + 2, 0), d(n + 2, 0);
      for (int I = 1; I <= n; ++I) {
        lo[I] = ax.idc[I] * ax.idf[I];
        hi[I] = ax.idc[I] * ax.idf[I + 1];
        d[I] = -(lo[I] + hi[I]);
      }
      if (!periodic[a] && bc[face(a, 0)] != ScalarBC::interface) {
        d[1] += bc[face(a, 0)] == ScalarBC::neumann ? lo[1] : -lo[1];
        lo[1] = 0;
      }
      if (!periodic[a] && bc[face(a, 1)] != ScalarBC::interface) {
        d[n] += bc[face(a, 1)] == ScalarBC::neumann ? hi[n] : -hi[n];
        hi[n] = 0;
      }
      for (int I = 0; I <= n + 1; ++I) {
        cl[a][I] = T(lo[I]);
        ch[a][I] = T(hi[I]);
        dg[a][I] = T(d[I]);
      }
    }
  }
  T diag(int i, int j, int k) const { return dg[0][i] + dg[1][j] + dg[2][k]; }
  T volume(int i, int j, int k) const { return vol[0][i] * vol[1][j] * vol[2][k]; }
};

// The stencil on one grid line (j, k) of a field x: row pointers and row constants, so that i loops vectorise.
template <class T>
struct StencilRow {
  const T* __restrict cxl;
  const T* __restrict cxh;
  const T* __restrict dgx;
  T cyl, cyh, czl, czh, dyz;
  const T *xc, *xs, *xn, *xb, *xt;  // x on the line and on its neighbour lines (south, north, bottom, top)
  StencilRow(const Stencil<T>& L, const T* x, int j, int k)
      : cxl(L.cl[0].data()), cxh(L.ch[0].data()), dgx(L.dg[0].data()), cyl(L.cl[1][j]), cyh(L.ch[1][j]),
        czl(L.cl[2][k]), czh(L.ch[2][k]), dyz(L.dg[1][j] + L.dg[2][k]) {
    xc = x + L.s(0, j, k);
    xs = xc - L.s.sy;
    xn = xc + L.s.sy;
    xb = xc - L.s.sz;
    xt = xc + L.s.sz;
  }
  T off(int i) const { return cxl[i] * xc[i - 1] + cxh[i] * xc[i + 1] + cyl * xs[i] + cyh * xn[i] + czl * xb[i] + czh * xt[i]; }
  T apply(int i) const { return off(i) + (dgx[i] + dyz) * xc[i]; }
};

// Ghost values of a padded array: periodic image, mirror (Neumann) or negated mirror (Dirichlet). xslot: where
// index i of an x line is stored, for arrays whose lines are permuted (the multigrid's split layout); the y and z
// faces treat every position of a line alike, so only the x faces need it.
template <class T>
void fill_scalar_ghosts(const Shape& s, T* x, const ScalarBCs& bc, const int* xslot = nullptr) {
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3, n = s.n(a);
    const std::ptrdiff_t sa = s.stride(a), sb = s.stride(b), sc = s.stride(c);
    const bool slots = a == 0 && xslot;
    const std::ptrdiff_t g0 = slots ? xslot[0] : 0, i1 = slots ? xslot[1] : sa, in = slots ? xslot[n] : n * sa,
                         g1 = slots ? xslot[n + 1] : (n + 1) * sa;
    const ScalarBC lo = bc[face(a, 0)], hi = bc[face(a, 1)];
    for (int kc = 0; kc <= s.n(c) + 1; ++kc)
      for (int kb = 0; kb <= s.n(b) + 1; ++kb) {
        T* l = x + kb * sb + kc * sc;
        if (lo == ScalarBC::periodic) {
          l[g0] = l[in];
          l[g1] = l[i1];
        } else {  // an interface's ghosts come from the neighbouring rank
          if (lo != ScalarBC::interface) l[g0] = lo == ScalarBC::neumann ? l[i1] : -l[i1];
          if (hi != ScalarBC::interface) l[g1] = hi == ScalarBC::neumann ? l[in] : -l[in];
        }
      }
  }
}

}  // namespace flapstab::ns
