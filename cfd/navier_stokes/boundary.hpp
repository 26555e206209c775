// Boundary conditions on the six faces of the box, and the ghost values that impose them.
#pragma once
#include <array>
#include <functional>
#include "cfd/navier_stokes/grid.hpp"
#include "core/types.hpp"

namespace flapstab::ns {

enum class BC {
  periodic,  // both faces of the axis; pressure periodic
  velocity,  // prescribed velocity (no-slip wall, moving lid, inflow); pressure Neumann
  outflow,   // zero normal gradient of every velocity component; pressure Dirichlet p = 0
  interface, // a cut between two ranks' slabs (decomposition.hpp): ghosts from the neighbour, nothing imposed
};

// Boundary condition of the pressure-like scalars (pressure, its increment, multigrid corrections).
enum class ScalarBC { periodic, neumann, dirichlet, interface };
using ScalarBCs = std::array<ScalarBC, 6>;  // indexed by face(axis, side)

constexpr int face(int axis, int side) { return 2 * axis + side; }  // side 0: lower, 1: upper

struct FaceCondition {
  BC type = BC::velocity;
  std::function<Vec3(double t)> velocity;  // BC::velocity only; empty means at rest
  // BC::velocity only: a velocity that varies over the face (e.g. the far field -V - Omega x r seen from a
  // rotating body frame); when set it replaces `velocity`, and the ghost filling needs the grid.
  std::function<Vec3(double t, const Vec3& x)> field;
  Vec3 at(double t) const { return velocity ? velocity(t) : Vec3::Zero(); }
  Vec3 at(double t, const Vec3& x) const { return field ? field(t, x) : at(t); }
};

// Conditions of faces x-, x+, y-, y+, z-, z+ (index face(axis, side)).
struct Boundaries {
  std::array<FaceCondition, 6> face;
  static Boundaries all(BC type);
  BC type(int axis, int side) const { return face[ns::face(axis, side)].type; }
  bool periodic(int axis) const { return type(axis, 0) == BC::periodic; }
  ScalarBCs pressure() const;
  // A rank's conditions: the z faces that are cuts of its slab become interfaces.
  Boundaries local(const Slab& s) const;
  // Throws unless periodic faces come in pairs and match the grid's periodic axes.
  void check(const Grid& g) const;
};

// Scalar ghosts: periodic image, mirror (Neumann) or negated mirror (Dirichlet zero on the face).
void fill_ghosts(Field& p, const ScalarBCs& bc);

// Boundary faces of the normal components at time t: prescribed, copied from the first interior face
// (outflow) or the periodic image. Called on the predicted velocity before projection.
// Faces with a `field` need the grid (std::invalid_argument without it).
void impose_normal_velocity(VectorField& u, const Boundaries& bc, double t, const Grid* grid = nullptr);

// Ghost values of every component at time t: periodic images, tangential wall values by the mirror
// 2 U - u, zero gradient at an outflow. Called after projection so stencils see BC-consistent data.
void fill_velocity_ghosts(VectorField& u, const Boundaries& bc, double t, const Grid* grid = nullptr);

}  // namespace flapstab::ns
