// The fluid region of a CFD grid around immersed parts as cut cells: the open fraction (aperture) of every cell
// face, each cell's fluid volume fraction, and the piece of each part's surface inside each cell as its area
// vector and moment (docs/theory/force-partitioning.md, "Discretisation").
//
// A face is sampled on an m x m lattice of points where a part's surface may cross it; a point belongs to the part
// whose level set is negative there (the lowest when several are). The surface inside a cell follows from the
// divergence theorem applied to the part's solid inside the cell: its faces' solid areas close it, so
//   int_{surface in c} n dS = - sum_faces s_f A_f n_f,   int_{surface in c} x x n dS = - sum_faces s_f A_f x_f x n_f
// (s_f the part's solid fraction of face f, n_f the cell's outward face normal, x_f the centroid of the face's
// solid points, n out of the part into the fluid). Over a closed part these sum to zero exactly, so the Neumann
// problems of the influence potentials are compatible; on a staircase (apertures 0 or 1) they reduce to the faces
// between fluid and solid cells.
#pragma once
#include <array>
#include <cstddef>
#include <functional>
#include <vector>
#include "cfd/navier_stokes/field.hpp"
#include "cfd/navier_stokes/grid.hpp"
#include "core/types.hpp"

namespace flapstab::fpm {

using ns::Field;
using ns::Grid;
using ns::Shape;

// Level set of part `part` at world point x for a face or cell of local width h: negative inside the part.
using LevelFunction = std::function<double(int part, const Vec3& x, double h)>;

struct FluidGeometry {
  Shape shape;
  int parts = 0;
  std::array<Field, 3> aperture;       // open fraction of face I (lower face of cell I) along d; the domain's faces 0
  Field volume_fraction;               // fluid fraction of each cell (mean of its six faces' open fractions)
  struct Cut {
    std::ptrdiff_t cell;               // Shape index of the cell the surface piece lies in
    int part;
    Vec3 area = Vec3::Zero();          // int n dS (m^2), n out of the part
    Vec3 moment = Vec3::Zero();        // int x x n dS about the grid origin (m^3)
    Vec3 centroid = Vec3::Zero();      // of the piece (m), for the surface acceleration
  };
  std::vector<Cut> cuts;
  // Faces the immersed boundary's direct forcing sets (per axis d, indexed like a Field of `shape`: 1 where the lowest
  // level set at the face centre lies below the face's local width h, the solid and interface-band faces of
  // docs/theory/navier-stokes.md §7). The momentum equation does not hold there; the partition's viscous term leaves
  // them out (docs/theory/force-partitioning.md, "Discretisation").
  std::array<std::vector<char>, 3> forced;
  struct Face {
    int d;
    int I[3];  // face index (the lower face of cell I along d)
  };
  std::vector<Face> forced_open;  // the forced faces with an open share, inside the domain (periodic: face 1 only)
  std::size_t sampled_faces = 0;       // faces the lattice sampled (near a surface)
  std::size_t pocket_cells = 0;        // fluid cells cut off from the domain's faces by the parts, taken out
  bool active(std::ptrdiff_t n) const { return volume_fraction[n] > 0; }
};

// `owners`: a hint, the part holding each interior cell's centre (x fastest, -1 fluid); faces of the cells within one
// cell (26-neighbourhood) of a solid cell are tested, the rest are open. `samples`: m of the m x m face lattice.
// Along a periodic axis d face n+1 is face 1: copies the values of faces 1 of a face field to faces n+1.
void copy_periodic_faces(Field& f, const Shape& s, int d);

// Which region the influence potentials treat as the parts (docs/theory/force-partitioning.md, "The partition's
// body"). surface: the parts as their level sets give them (cut-cell apertures from the m x m face lattice);
// forced_region: the parts widened to every face the immersed boundary forces (lowest level set at the face centre
// below the local width h), closed whole, so that the momentum equation holds on every open face.
enum class FpmBody { surface, forced_region };

// `near` (optional, x fastest, >= 0 where set): the cells from which faces are tested, dilated by one; by default the
// owners. A membrane's forcing band reaches 1.6 local widths from its mid-surface and wraps round its edges, beyond a
// dilation of the cells whose centres it holds: pass the band's cells (ImmersedBoundary::cell_owners with reach 1).
FluidGeometry fluid_geometry(const Grid& g, int parts, const LevelFunction& level, const std::vector<int>& owners,
                             int samples = 4, FpmBody body = FpmBody::surface, const std::vector<int>* near = nullptr);

// The cell owners for an analytic level function (every cell centre evaluated), for tests and small grids.
std::vector<int> owners_of(const Grid& g, int parts, const LevelFunction& level);

}  // namespace flapstab::fpm
