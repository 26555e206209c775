// Ghost-layer filling for the box boundary conditions (one plane sweep per face, axes in order x, y, z so
// that edge and corner ghosts are consistent).
#include "cfd/navier_stokes/boundary.hpp"
#include "cfd/navier_stokes/stencil.hpp"
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
    s[f] = face[f].type == BC::periodic ? ScalarBC::periodic
         : face[f].type == BC::outflow  ? ScalarBC::dirichlet
                                        : ScalarBC::neumann;
  return s;
}

void Boundaries::check(const Grid& g) const {
  for (int a = 0; a < 3; ++a) {
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

void impose_normal_velocity(VectorField& u, const Boundaries& bc, double t) {
  for (int a = 0; a < 3; ++a) {
    if (bc.periodic(a)) {  // face n+1 is face 1
      real* q = u[a].data();
      for_each_line(u[a].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n) { q[o + (n + 1) * s] = q[o + s]; });
      continue;
    }
    const FaceCondition &lo = bc.face[face(a, 0)], &hi = bc.face[face(a, 1)];
    const real ulo = lo.at(t)[a], uhi = hi.at(t)[a];
    real* q = u[a].data();
    for_each_line(u[a].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n) {
      real* l = q + o;
      l[s] = lo.type == BC::velocity ? ulo : l[2 * s];
      l[(n + 1) * s] = hi.type == BC::velocity ? uhi : l[n * s];
    });
  }
}

void fill_velocity_ghosts(VectorField& u, const Boundaries& bc, double t) {
  for (int a = 0; a < 3; ++a) {
    const FaceCondition &lo = bc.face[face(a, 0)], &hi = bc.face[face(a, 1)];
    const Vec3 Ulo = lo.at(t), Uhi = hi.at(t);
    for (int d = 0; d < 3; ++d) {
      real* q = u[d].data();
      for_each_line(u[d].shape(), a, [&](std::ptrdiff_t o, std::ptrdiff_t s, int n) {
        real* l = q + o;
        if (lo.type == BC::periodic) {
          l[0] = l[n * s];
          l[(n + 1) * s] = l[s];
        } else if (d == a) {  // boundary faces are set; the outer ghost only needs a finite value
          l[0] = l[s];
        } else {
          l[0] = lo.type == BC::velocity ? 2 * Ulo[d] - l[s] : l[s];
          l[(n + 1) * s] = hi.type == BC::velocity ? 2 * Uhi[d] - l[n * s] : l[n * s];
        }
      });
    }
  }
}

}  // namespace flapstab::ns
