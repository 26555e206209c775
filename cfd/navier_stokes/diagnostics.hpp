// Flow diagnostics at the cell centres: velocity, vorticity and the Q criterion (for field output, and the
// volume integrals of force partitioning).
#pragma once
#include <vector>
#include "cfd/navier_stokes/field.hpp"
#include "cfd/navier_stokes/grid.hpp"

namespace flapstab::ns {

// Cell-centre velocity, vorticity and Q criterion (central differences on the non-uniform centres, one-sided at
// the domain faces), each an array over the interior cells, x fastest.
struct CentreFields {
  std::vector<double> u[3], w[3], q;
};
CentreFields centre_fields(const Grid& g, const VectorField& u);

}  // namespace flapstab::ns
