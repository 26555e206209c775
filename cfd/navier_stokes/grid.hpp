// Non-uniform Cartesian grid: per-direction face coordinates and the metric factors of the MAC operators.
#pragma once
#include <algorithm>
#include <array>
#include <vector>
#include "cfd/navier_stokes/decomposition.hpp"
#include "cfd/navier_stokes/field.hpp"

namespace flapstab::ns {

// Generator of one direction: a uniform fine box [box_lo, box_hi] with spacing <= h, geometric stretching
// with ratio <= max_ratio from the box out to the domain bounds [lo, hi]; the cell count is rounded up to a
// multiple of `multiple_of` (so multigrid can coarsen it). box_lo = lo and box_hi = hi give a uniform axis.
struct StretchedAxis {
  double lo = 0, hi = 1;
  double box_lo = 0, box_hi = 1;
  double h = 0.1;
  double max_ratio = 1.05;
  int multiple_of = 8;
  int box_cells = 0;  // > 0: exactly this many cells in the fine box (a box re-planned on an earlier grid's lattice)
  // The same mapping sampled twice as densely: h/2 and sqrt(ratio) (for convergence studies).
  StretchedAxis refined() const;
};

// One direction of the grid. Arrays are indexed like Shape: I = 1..n are cells (0, n+1 ghosts, mirrored at a
// wall or wrapped when periodic); face I is the LOWER face of cell I, so faces 1 and n+1 bound the domain.
class Axis {
 public:
  Axis(std::vector<double> faces, bool periodic);  // faces: n+1 strictly increasing coordinates
  static Axis uniform(double lo, double hi, int n, bool periodic);
  static Axis stretched(const StretchedAxis& spec, bool periodic);

  int n = 0;
  bool periodic = false;
  // A rank's part of a decomposed axis (slice()): a cut face's ghost comes from the neighbouring rank, and the
  // staggered unknown on it belongs to the rank above (face 1 of a lower cut is an unknown here, face n + 1 of an
  // upper cut is not), as on a periodic axis.
  bool cut_lo = false, cut_hi = false;
  double lo = 0, hi = 0;
  // padded arrays, size n+2
  std::vector<double> xc;    // cell centre
  std::vector<double> xf;    // lower face of cell I
  std::vector<double> dc;    // cell width  xf[I+1] - xf[I]
  std::vector<double> df;    // centre spacing across face I: xc[I] - xc[I-1] (I >= 1)
  std::vector<double> idc, idf;  // 1/dc, 1/df
  std::vector<double> wlo, whi;  // linear interpolation to face I: wlo[I] v[I-1] + whi[I] v[I]
  std::vector<double> dv;    // width of the control volume of a staggered unknown on face I (half cell at a wall)

  double length() const { return hi - lo; }
  double min_width() const;
  double max_ratio() const;  // largest ratio of neighbouring cell widths (across the periodic seam too)
  bool can_coarsen() const { return n % 2 == 0; }
  Axis coarsened() const;    // every other face
  // Cells offset + 1 .. offset + n of this axis as a rank's part, with its cuts; the metric arrays (ghosts
  // included) are this axis's own at those indices.
  Axis slice(const Slab& s) const;
  // Whether face 1 (lower) is a staggered unknown of this rank, and whether face n + 1 (upper) is a boundary
  // face it owns: an unknown of the rank above, or the periodic image of face 1, otherwise.
  bool lower_face_unknown() const { return periodic || cut_lo; }
  bool owns_upper_face() const { return !periodic && !cut_hi; }
};

// Where x falls on coordinates c[lo..hi] (increasing): index i with c[i] <= x < c[i+1], clamped to [lo, hi - 1], and
// the linear weight of c[i+1], clamped to [0, 1] (so x outside the range takes the end value).
inline void bracket(const std::vector<double>& c, int lo, int hi, double x, int& i, double& w) {
  const auto first = c.begin() + lo, last = c.begin() + hi + 1;
  i = int(std::upper_bound(first, last, x) - c.begin()) - 1;
  i = std::clamp(i, lo, hi - 1);
  w = std::clamp((x - c[std::size_t(i)]) / (c[std::size_t(i) + 1] - c[std::size_t(i)]), 0.0, 1.0);
}

// The trilinear combination of f's values at (I, J, K) ... (I + 1, J + 1, K + 1), W the weights of the upper ones.
inline double trilinear(const Field& f, const int I[3], const double W[3]) {
  double v = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? W[0] : 1 - W[0]) * (dy ? W[1] : 1 - W[1]) * (dz ? W[2] : 1 - W[2]);
    if (w != 0) v += w * f(I[0] + dx, I[1] + dy, I[2] + dz);
  }
  return v;
}

// Three axes; the tensor product of their cells is the grid.
struct Grid {
  std::array<Axis, 3> axis;
  Grid(Axis x, Axis y, Axis z) : axis{std::move(x), std::move(y), std::move(z)} {}
  Shape shape() const { return Shape(axis[0].n, axis[1].n, axis[2].n); }
  std::size_t cells() const { return shape().cells(); }
  double volume(int i, int j, int k) const { return axis[0].dc[i] * axis[1].dc[j] * axis[2].dc[k]; }
  // Where component d of a staggered vector lives at index (i, j, k): face along d, cell centre otherwise.
  std::array<double, 3> point(int d, int i, int j, int k) const {
    const int I[3] = {i, j, k};
    std::array<double, 3> x;
    for (int a = 0; a < 3; ++a) x[a] = a == d ? axis[a].xf[I[a]] : axis[a].xc[I[a]];
    return x;
  }
  std::array<double, 3> centre(int i, int j, int k) const { return {axis[0].xc[i], axis[1].xc[j], axis[2].xc[k]}; }
  Grid slice_z(const Slab& s) const { return Grid(axis[0], axis[1], axis[2].slice(s)); }  // a rank's slab
};

}  // namespace flapstab::ns
