// Axis construction (uniform, stretched, from faces), metric factors with ghost cells, coarsening.
#include "cfd/navier_stokes/grid.hpp"
#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace flapstab::ns {

namespace {

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument("navier_stokes grid: " + what); }

// Widths of m cells growing outwards from h by the ratio q that makes them fill exactly `length`:
// h (q + q^2 + ... + q^m) = length with q in [1, max_ratio]; m is the fewest cells that can do it, plus `extra`.
std::vector<double> geometric_widths(double length, double h, double max_ratio, int extra) {
  if (length <= 0) return {};
  auto sum = [h](double q, int m) { return q == 1.0 ? h * m : h * q * (std::pow(q, m) - 1) / (q - 1); };
  int m = 1;
  while (sum(max_ratio, m) < length * (1 - 1e-12)) ++m;
  m += extra;
  if (h * m >= length) return std::vector<double>(m, length / m);  // too short to stretch: uniform, <= h
  double a = 1.0, b = max_ratio;  // sum(a) < length <= sum(b)
  for (int it = 0; it < 200; ++it) {
    const double q = 0.5 * (a + b);
    (sum(q, m) < length ? a : b) = q;
  }
  const double q = 0.5 * (a + b);
  std::vector<double> w(m);
  double x = h;
  for (int k = 0; k < m; ++k) w[k] = (x *= q);
  const double scale = length / std::accumulate(w.begin(), w.end(), 0.0);  // removes the bisection's residue
  for (double& v : w) v *= scale;
  return w;
}

}  // namespace

StretchedAxis StretchedAxis::refined() const {
  StretchedAxis r = *this;
  r.h = h / 2;
  r.max_ratio = std::sqrt(max_ratio);
  r.box_cells = 2 * box_cells;
  return r;
}

Axis::Axis(std::vector<double> faces, bool periodic_) : n(int(faces.size()) - 1), periodic(periodic_) {
  if (n < 1) bad("an axis needs at least 1 cell");
  for (int i = 0; i < n; ++i)
    if (!(faces[i + 1] > faces[i])) bad("face coordinates must increase strictly (face " + std::to_string(i) + ")");
  lo = faces.front();
  hi = faces.back();
  const int m = n + 2;
  dc.assign(m, 0);
  xc.assign(m, 0);
  for (int I = 1; I <= n; ++I) {
    dc[I] = faces[I] - faces[I - 1];
    xc[I] = 0.5 * (faces[I] + faces[I - 1]);
  }
  // Ghost cells: the periodic image, or the mirror image of the boundary cell.
  dc[0] = periodic ? dc[n] : dc[1];
  dc[n + 1] = periodic ? dc[1] : dc[n];
  xc[0] = lo - 0.5 * dc[0];
  xc[n + 1] = hi + 0.5 * dc[n + 1];
  xf.assign(m, 0);
  for (int I = 0; I < m; ++I) xf[I] = xc[I] - 0.5 * dc[I];
  df.assign(m, 0);
  wlo.assign(m, 0.5);
  whi.assign(m, 0.5);
  for (int I = 1; I < m; ++I) {
    df[I] = xc[I] - xc[I - 1];
    wlo[I] = dc[I] / (dc[I - 1] + dc[I]);
    whi[I] = dc[I - 1] / (dc[I - 1] + dc[I]);
  }
  df[0] = periodic ? df[n] : dc[0];
  idc.resize(m);
  idf.resize(m);
  for (int I = 0; I < m; ++I) {
    idc[I] = 1 / dc[I];
    idf[I] = 1 / df[I];
  }
  dv = df;
  if (!periodic) {
    dv[1] = 0.5 * dc[1];
    dv[n + 1] = 0.5 * dc[n];
  }
}

Axis Axis::uniform(double lo, double hi, int n, bool periodic) {
  if (!(hi > lo)) bad("uniform axis needs hi > lo");
  if (n < 1) bad("uniform axis needs n >= 1, got " + std::to_string(n));
  std::vector<double> f(n + 1);
  for (int i = 0; i <= n; ++i) f[i] = lo + (hi - lo) * i / n;
  f[n] = hi;
  return Axis(std::move(f), periodic);
}

Axis Axis::stretched(const StretchedAxis& s, bool periodic) {
  if (!(s.hi > s.lo)) bad("stretched axis needs hi > lo");
  if (!(s.lo <= s.box_lo && s.box_lo < s.box_hi && s.box_hi <= s.hi))
    bad("stretched axis needs lo <= box_lo < box_hi <= hi");
  if (!(s.h > 0)) bad("stretched axis needs a fine spacing h > 0");
  if (!(s.max_ratio >= 1.0 && s.max_ratio <= 1.1))
    bad("stretching ratio must lie in [1, 1.1] (second order needs smooth stretching), got " + std::to_string(s.max_ratio));
  if (s.multiple_of < 1) bad("multiple_of must be >= 1");
  if (s.box_cells < 0) bad("box_cells must be >= 0");
  const int n_box0 = s.box_cells > 0 ? s.box_cells : std::max(1, int(std::ceil((s.box_hi - s.box_lo) / s.h - 1e-9)));
  if (n_box0 > 1 << 20) bad("fine box holds more than 2^20 cells per direction; check h");
  const double len_lo = s.box_lo - s.lo, len_hi = s.hi - s.box_hi;
  // The fewest cells whose count is a multiple of `multiple_of`: up to multiple_of - 1 more in the box, up to
  // multiple_of more on each side (lowering its ratio, never below 1); ties go to the candidate whose two sides
  // stretch most alike. A periodic axis also bounds the jump between the outer cells that meet across the seam.
  auto ratio = [](const std::vector<double>& w) { return w.size() < 2 ? 1.0 : w[1] / w[0]; };
  int n_box = 0, best_total = 1 << 30;
  double best_balance = 1e300;
  std::vector<double> w_lo, w_hi;
  for (int b = n_box0; b < n_box0 + (s.box_cells > 0 ? 1 : s.multiple_of); ++b) {
    const double h = (s.box_hi - s.box_lo) / b;
    for (int el = 0; el <= s.multiple_of; ++el)
      for (int eh = 0; eh <= s.multiple_of; ++eh) {
        auto lo = geometric_widths(len_lo, h, s.max_ratio, el), hi = geometric_widths(len_hi, h, s.max_ratio, eh);
        if ((el > 0 && ratio(lo) < 1.0 + 1e-12) || (eh > 0 && ratio(hi) < 1.0 + 1e-12)) continue;  // over-filled
        const int total = b + int(lo.size() + hi.size());
        const double a = lo.empty() ? h : lo.back(), c = hi.empty() ? h : hi.back();
        if (total % s.multiple_of != 0 || total > best_total) continue;
        if (periodic && std::max(a, c) > s.max_ratio * (1 + 1e-12) * std::min(a, c)) continue;
        const double balance = (lo.empty() || hi.empty()) ? 0.0 : std::abs(ratio(lo) - ratio(hi));
        if (total == best_total && balance >= best_balance) continue;
        best_total = total;
        best_balance = balance;
        n_box = b;
        w_lo = std::move(lo);
        w_hi = std::move(hi);
      }
  }
  if (n_box == 0) bad("no stretched axis with a cell count multiple of " + std::to_string(s.multiple_of) + " fits; lower multiple_of");
  const double h = (s.box_hi - s.box_lo) / n_box;
  std::vector<double> f;
  f.reserve(n_box + w_lo.size() + w_hi.size() + 1);
  double x = s.lo;
  f.push_back(x);
  for (auto it = w_lo.rbegin(); it != w_lo.rend(); ++it) f.push_back(x += *it);
  if (!w_lo.empty()) f.back() = s.box_lo;
  for (int i = 1; i <= n_box; ++i) f.push_back(s.box_lo + h * i);
  f.back() = s.box_hi;
  x = s.box_hi;
  for (double w : w_hi) f.push_back(x += w);
  f.back() = s.hi;
  return Axis(std::move(f), periodic);
}

double Axis::min_width() const { return *std::min_element(dc.begin() + 1, dc.begin() + n + 1); }

double Axis::max_ratio() const {
  double r = 1;
  const int last = periodic ? n + 1 : n;
  for (int I = 2; I <= last; ++I) r = std::max({r, dc[I] / dc[I - 1], dc[I - 1] / dc[I]});
  return r;
}

Axis Axis::slice(const Slab& s) const {
  if (s.n < 1 || s.offset < 0 || s.offset + s.n > n)
    bad("slab of cells " + std::to_string(s.offset + 1) + ".." + std::to_string(s.offset + s.n) +
        " outside the axis of " + std::to_string(n));
  if (!(s.cut_lo || s.cut_hi)) return *this;
  Axis a = *this;
  a.n = s.n;
  a.periodic = false;
  a.cut_lo = s.cut_lo;
  a.cut_hi = s.cut_hi;
  for (auto* v : {&a.xc, &a.xf, &a.dc, &a.df, &a.idc, &a.idf, &a.wlo, &a.whi, &a.dv})
    *v = std::vector<double>(v->begin() + s.offset, v->begin() + s.offset + s.n + 2);
  a.lo = a.xf[1];
  a.hi = a.xf[std::size_t(s.n + 1)];
  return a;
}

Axis Axis::coarsened() const {
  if (cut_lo || cut_hi) bad("a rank's part of an axis is not coarsened (slice the coarsened whole axis)");
  if (!can_coarsen()) bad("axis of " + std::to_string(n) + " cells cannot be coarsened by 2");
  std::vector<double> f(n / 2 + 1);
  for (int i = 0; i <= n / 2; ++i) f[i] = xf[2 * i + 1];
  return Axis(std::move(f), periodic);
}

}  // namespace flapstab::ns
