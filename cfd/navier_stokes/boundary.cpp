// Ghost-layer filling for the box boundary conditions (one plane sweep per face, axes in order x, y, z so
// that edge and corner ghosts are consistent).
#include "cfd/navier_stokes/boundary.hpp"
#include "cfd/navier_stokes/stencil.hpp"
#include <algorithm>
#include <stdexcept>
#include <string>

namespace flapstab::ns {

namespace {

// Calls f(line, stride, n) for every grid line along `axis` (other indices over the padded range).
template <class F>
void for_each_line(const Shape& s, int axis, F&& f) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const std::ptrdiff_t sb = s.stride(b), sc = s.stride(c), sa = s.stride(axis);
  for (int kc = 0; kc <= s.n(c) + 1; ++kc)
    for (int kb = 0; kb <= s.n(b) + 1; ++kb) f(kb * sb + kc * sc, sa, s.n(axis));
}

// The same with the line's indices along the other two axes.
template <class F>
void for_each_line_at(const Shape& s, int axis, F&& f) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const std::ptrdiff_t sb = s.stride(b), sc = s.stride(c), sa = s.stride(axis);
  for (int kc = 0; kc <= s.n(c) + 1; ++kc)
    for (int kb = 0; kb <= s.n(b) + 1; ++kb) f(kb * sb + kc * sc, sa, s.n(axis), kb, kc);
}

// Position on the boundary face (side 0: lower, 1: upper) of `axis` for component d on the line (kb, kc): the
// face coordinate along axis, and component d's staggered location along the other two.
Vec3 wall_point(const Grid& g, int axis, int side, int d, int kb, int kc) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const Axis& A = g.axis[std::size_t(axis)];
  Vec3 x;
  x[axis] = side == 0 ? A.xf[1] : A.xf[std::size_t(A.n + 1)];
  auto along = [&](int e, int k) {
    const Axis& E = g.axis[std::size_t(e)];
    const int kk = std::clamp(k, 0, E.n + 1);
    return e == d ? E.xf[std::size_t(std::max(kk, 1))] : E.xc[std::size_t(kk)];
  };
  x[b] = along(b, kb);
  x[c] = along(c, kc);
  return x;
}

void need_grid(const FaceCondition& f, const Grid* g) {
  if (f.field && !g) throw std::invalid_argument("navier_stokes boundaries: a face velocity field needs the grid");
}

const char* name(int f) {
  static const char* names[6] = {"x-", "x+", "y-", "y+", "z-", "z+"};
  return names[f];
}

}  // namespace

Boundaries Boundaries::all(BC type) {
  Boundaries b;
  for (auto& f : b.face) f.type = type;
  return b;
}

ScalarBCs Boundaries::pressure() const {
  ScalarBCs s{};
  for (int f = 0; f < 6; ++f)
    s[f] = face[f].type == BC::periodic  ? ScalarBC::periodic
         : face[f].type == BC::outflow   ? ScalarBC::dirichlet
         : face[f].type == BC::interface ? ScalarBC::interface
                                         : ScalarBC::neumann;
  return s;
}

Boundaries Boundaries::local(const Slab& s) const {
  Boundaries b = *this;
  if (s.cut_lo || s.cut_hi) {  // a periodic z axis split over ranks has two cuts: no face keeps its periodic pair
    if (s.cut_lo) b.face[std::size_t(ns::face(2, 0))] = FaceCondition{BC::interface, {}, {}};
    if (s.cut_hi) b.face[std::size_t(ns::face(2, 1))] = FaceCondition{BC::interface, {}, {}};
  }
  return b;
}

void Boundaries::check(const Grid& g) const {
  for (int a = 0; a < 3; ++a) {
    const bool cut[2] = {g.axis[a].cut_lo, g.axis[a].cut_hi};
    for (int side = 0; side < 2; ++side)
      if ((type(a, side) == BC::interface) != cut[side])
        throw std::invalid_argument(std::string("navier_stokes boundaries: face ") + name(ns::face(a, side)) +
                                    (cut[side] ? " is a cut between ranks but not an interface"
                                               : " is an interface but the grid has no cut there"));
    const bool lo = type(a, 0) == BC::periodic, hi = type(a, 1) == BC::periodic;
    if (lo != hi)
      throw std::invalid_argument(std::string("navier_stokes boundaries: face ") + name(ns::face(a, lo ? 0 : 1)) +
                                  " is periodic but its opposite face is not");
    if (lo != g.axis[a].periodic)
      throw std::invalid_argument(std::string("navier_stokes boundaries: faces ") + name(ns::face(a, 0)) + "/" +
                                  name(ns::face(a, 1)) + (lo ? " are periodic but the grid axis is not"
                                                         : " are not periodic but the grid axis is"));
  }
}

void fill_ghosts(Field& p, const ScalarBCs& bc) { fill_scalar_ghosts(p.shape(), p.data(), bc); }

void impose_normal_velocity(VectorField& u, const Boundaries& bc, double t, const Grid* grid) {
  for (int a = 0; a < 3; ++a) {
    if (bc.periodic(a)) {  // face n+1 is face 1
      real* q = u[a].data();
      for_each_line(u[a].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n) { q[o + (n + 1) * s] = q[o + s]; });
      continue;
    }
    const FaceCondition &lo = bc.face[face(a, 0)], &hi = bc.face[face(a, 1)];
    const real ulo = lo.at(t)[a], uhi = hi.at(t)[a];
    real* q = u[a].data();
    if (lo.field || hi.field) {
      need_grid(lo, grid);
      need_grid(hi, grid);
      for_each_line_at(u[a].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n, int kb, int kc) {
        real* l = q + o;
        if (lo.type != BC::interface)
          l[s] = lo.type != BC::velocity ? l[2 * s]
                 : lo.field              ? real(lo.at(t, wall_point(*grid, a, 0, a, kb, kc))[a])
                                         : ulo;
        if (hi.type != BC::interface)
          l[(n + 1) * s] = hi.type != BC::velocity ? l[n * s]
                           : hi.field              ? real(hi.at(t, wall_point(*grid, a, 1, a, kb, kc))[a])
                                                   : uhi;
      });
      continue;
    }
    for_each_line(u[a].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n) {
      real* l = q + o;
      if (lo.type != BC::interface) l[s] = lo.type == BC::velocity ? ulo : l[2 * s];
      if (hi.type != BC::interface) l[(n + 1) * s] = hi.type == BC::velocity ? uhi : l[n * s];
    });
  }
}

void fill_velocity_ghosts(VectorField& u, const Boundaries& bc, double t, const Grid* grid) {
  for (int a = 0; a < 3; ++a) {
    const FaceCondition &lo = bc.face[face(a, 0)], &hi = bc.face[face(a, 1)];
    const Vec3 Ulo = lo.at(t), Uhi = hi.at(t);
    for (int d = 0; d < 3; ++d) {
      real* q = u[d].data();
      if ((lo.field || hi.field) && d != a) {  // tangential ghosts mirror the wall value at the wall point
        need_grid(lo, grid);
        need_grid(hi, grid);
        for_each_line_at(u[d].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n, int kb, int kc) {
          real* l = q + o;
          const double wl = lo.field ? lo.at(t, wall_point(*grid, a, 0, d, kb, kc))[d] : Ulo[d];
          const double wh = hi.field ? hi.at(t, wall_point(*grid, a, 1, d, kb, kc))[d] : Uhi[d];
          if (lo.type != BC::interface) l[0] = lo.type == BC::velocity ? real(2 * wl) - l[s] : l[s];
          if (hi.type != BC::interface) l[(n + 1) * s] = hi.type == BC::velocity ? real(2 * wh) - l[n * s] : l[n * s];
        });
        continue;
      }
      for_each_line(u[d].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n) {
        real* l = q + o;
        if (lo.type == BC::periodic) {
          l[0] = l[n * s];
          l[(n + 1) * s] = l[s];
        } else if (d == a) {  // boundary faces are set; the outer ghost only needs a finite value
          if (lo.type != BC::interface) l[0] = l[s];
        } else {
          if (lo.type != BC::interface) l[0] = lo.type == BC::velocity ? 2 * Ulo[d] - l[s] : l[s];
          if (hi.type != BC::interface) l[(n + 1) * s] = hi.type == BC::velocity ? 2 * Uhi[d] - l[n * s] : l[n * s];
        }
      });
    }
  }
}

}  // namespace flapstab::ns
