// Grid of the Navier-Stokes solver: uniform and stretched axes (spacing, ratio, bounds, cell-count rounding),
// ghost-cell metrics, coarsening, input validation, and the box boundary-condition checks.
#include <gtest/gtest.h>
#include <cmath>
#include "cfd/navier_stokes/boundary.hpp"
#include "cfd/navier_stokes/grid.hpp"
#include "cfd/navier_stokes/multigrid.hpp"

namespace {

using namespace flapstab::ns;

void expect_consistent(const Axis& a) {
  EXPECT_DOUBLE_EQ(a.xf[1], a.lo);
  EXPECT_NEAR(a.xf[a.n + 1], a.hi, 1e-12 * (a.hi - a.lo));
  double total = 0;
  for (int I = 1; I <= a.n; ++I) {
    EXPECT_GT(a.dc[I], 0);
    EXPECT_NEAR(a.xc[I], 0.5 * (a.xf[I] + a.xf[I + 1]), 1e-13);
    EXPECT_NEAR(a.wlo[I] + a.whi[I], 1.0, 1e-15);
    EXPECT_NEAR(a.wlo[I] * a.xc[I - 1] + a.whi[I] * a.xc[I], a.xf[I], 1e-13);  // linear interpolation hits the face
    total += a.dc[I];
  }
  for (int I = 1; I <= a.n + 1; ++I) EXPECT_NEAR(a.df[I], a.xc[I] - a.xc[I - 1], 1e-13);
  EXPECT_NEAR(total, a.hi - a.lo, 1e-12);
}

TEST(NavierStokesGrid, UniformAxisMetricsAndGhosts) {
  const Axis a = Axis::uniform(-1, 3, 8, false);
  expect_consistent(a);
  EXPECT_DOUBLE_EQ(a.dc[1], 0.5);
  EXPECT_DOUBLE_EQ(a.xc[0], -1.25);  // mirror image of cell 1
  EXPECT_DOUBLE_EQ(a.dv[1], 0.25);   // half control volume of a boundary face
  EXPECT_DOUBLE_EQ(a.dv[4], 0.5);
  const Axis p = Axis::uniform(0, 1, 4, true);
  expect_consistent(p);
  EXPECT_DOUBLE_EQ(p.xc[0], -0.125);  // periodic image of cell 4
  EXPECT_DOUBLE_EQ(p.dv[1], 0.25);
}

TEST(NavierStokesGrid, StretchedAxisKeepsSpacingRatioAndBounds) {
  const StretchedAxis spec{-4, 6, -0.5, 1.5, 0.05, 1.08, 8};
  for (bool periodic : {false, true}) {
    const Axis a = Axis::stretched(spec, periodic);
    expect_consistent(a);
    EXPECT_EQ(a.n % 8, 0);
    EXPECT_LE(a.max_ratio(), 1.08 + 1e-12);
    EXPECT_LE(a.min_width(), 0.05 + 1e-12);
    int in_box = 0;  // the box is uniform with spacing <= h
    double h = 0;
    for (int I = 1; I <= a.n; ++I)
      if (a.xc[I] > -0.5 && a.xc[I] < 1.5) {
        if (in_box++ == 0) h = a.dc[I];
        EXPECT_NEAR(a.dc[I], h, 1e-12);
      }
    EXPECT_LE(h, 0.05 + 1e-12);
    EXPECT_NEAR(in_box * h, 2.0, 1e-9);
    EXPECT_GT(*std::max_element(a.dc.begin() + 1, a.dc.begin() + a.n + 1), 5 * h);  // it did stretch
  }
  const Axis coarse = Axis::stretched(spec, false), fine = Axis::stretched(spec.refined(), false);
  EXPECT_NEAR(double(fine.n) / coarse.n, 2.0, 0.15);
}

// A box and margins symmetric about 0 (the lateral axis of a symmetric insect, y = 0 its plane of symmetry) give
// faces symmetric about 0: x_f(i) = -x_f(n - i) to rounding (1e-12 of the length), so mirror-image faces have the
// same widths and the flow of a symmetric insect can stay symmetric. Several spacings, ratios and margins.
TEST(NavierStokesGrid, SymmetricSpecificationGivesASymmetricAxis) {
  int checked = 0;
  for (double h : {0.05, 0.047, 0.031, 0.0123})
    for (double ratio : {1.0, 1.03, 1.05, 1.08})
      for (double margin : {0.0, 0.7, 2.9}) {
        if (ratio == 1.0 && margin > 0) continue;  // unstretched margins need not fit whole cells
        const StretchedAxis spec{-1.3 - margin, 1.3 + margin, -1.3, 1.3, h, ratio, 8};
        const Axis a = Axis::stretched(spec, false);
        ASSERT_EQ(a.n % 8, 0);
        for (int i = 0; i <= a.n; ++i)
          EXPECT_NEAR(a.xf[std::size_t(i + 1)], -a.xf[std::size_t(a.n - i + 1)], 1e-12 * (2.6 + 2 * margin))
              << "h " << h << " ratio " << ratio << " margin " << margin << " face " << i << " of " << a.n;
        ++checked;
      }
  EXPECT_EQ(checked, 40);
}

TEST(NavierStokesGrid, StretchedAxisWithoutStretchingIsUniform) {
  const Axis a = Axis::stretched(StretchedAxis{0, 1, 0, 1, 0.1, 1.05, 1}, false);
  EXPECT_EQ(a.n, 10);
  EXPECT_NEAR(a.max_ratio(), 1.0, 1e-12);
}

TEST(NavierStokesGrid, RejectsInvalidInput) {
  EXPECT_THROW(Axis::stretched(StretchedAxis{0, 1, 0.4, 0.6, 0.01, 1.2, 8}, false), std::invalid_argument);   // ratio > 1.1
  EXPECT_THROW(Axis::stretched(StretchedAxis{0, 1, 0.4, 0.6, 0.01, 0.95, 8}, false), std::invalid_argument);  // ratio < 1
  EXPECT_THROW(Axis::stretched(StretchedAxis{0, 1, 0.4, 0.6, 0.0, 1.05, 8}, false), std::invalid_argument);   // h <= 0
  EXPECT_THROW(Axis::stretched(StretchedAxis{0, 1, -0.1, 0.6, 0.01, 1.05, 8}, false), std::invalid_argument); // box outside
  EXPECT_THROW(Axis::stretched(StretchedAxis{0, 1, 0.6, 0.4, 0.01, 1.05, 8}, false), std::invalid_argument);  // empty box
  EXPECT_THROW(Axis::stretched(StretchedAxis{0, 1, 0.4, 0.6, 0.01, 1.05, 0}, false), std::invalid_argument);  // multiple_of
  EXPECT_THROW(Axis::uniform(1, 0, 8, false), std::invalid_argument);
  EXPECT_THROW(Axis::uniform(0, 1, 0, false), std::invalid_argument);
  EXPECT_THROW(Axis({0.0, 0.5, 0.5, 1.0}, false), std::invalid_argument);  // faces must increase
  try {
    Axis::stretched(StretchedAxis{0, 1, 0.4, 0.6, 0.01, 1.2, 8}, false);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ratio"), std::string::npos) << e.what();
  }
}

TEST(NavierStokesGrid, CoarseningTakesEveryOtherFace) {
  const Axis a = Axis::stretched(StretchedAxis{0, 1, 0.3, 0.7, 0.05, 1.1, 4}, false);
  ASSERT_TRUE(a.can_coarsen());
  const Axis c = a.coarsened();
  EXPECT_EQ(c.n, a.n / 2);
  for (int I = 1; I <= c.n + 1; ++I) EXPECT_DOUBLE_EQ(c.xf[I], a.xf[2 * I - 1]);
  EXPECT_FALSE(Axis::uniform(0, 1, 5, false).can_coarsen());
  EXPECT_THROW(Axis::uniform(0, 1, 5, false).coarsened(), std::invalid_argument);
}

TEST(NavierStokesGrid, StaggeredPointsAndVolumes) {
  const Grid g(Axis::uniform(0, 1, 4, false), Axis::uniform(0, 2, 4, false), Axis::uniform(0, 3, 3, true));
  EXPECT_EQ(g.cells(), 48u);
  EXPECT_DOUBLE_EQ(g.volume(1, 1, 1), 0.25 * 0.5 * 1.0);
  const auto u = g.point(0, 1, 1, 1), v = g.point(1, 1, 1, 1), c = g.centre(1, 1, 1);
  EXPECT_DOUBLE_EQ(u[0], 0.0);   // u on the lower x face
  EXPECT_DOUBLE_EQ(u[1], 0.25);  // at the cell centre in y
  EXPECT_DOUBLE_EQ(v[1], 0.0);
  EXPECT_DOUBLE_EQ(c[2], 0.5);
}

TEST(NavierStokesGrid, BoundaryConditionsMustMatchThePeriodicAxes) {
  const Grid g(Axis::uniform(0, 1, 4, true), Axis::uniform(0, 1, 4, false), Axis::uniform(0, 1, 4, false));
  Boundaries b = Boundaries::all(BC::velocity);
  EXPECT_THROW(b.check(g), std::invalid_argument);  // x is periodic in the grid but not in the conditions
  b.face[face(0, 0)].type = BC::periodic;
  EXPECT_THROW(b.check(g), std::invalid_argument);  // only one of the pair
  b.face[face(0, 1)].type = BC::periodic;
  EXPECT_NO_THROW(b.check(g));
  b.face[face(1, 1)].type = BC::outflow;
  const ScalarBCs p = b.pressure();
  EXPECT_EQ(p[face(0, 0)], ScalarBC::periodic);
  EXPECT_EQ(p[face(1, 0)], ScalarBC::neumann);
  EXPECT_EQ(p[face(1, 1)], ScalarBC::dirichlet);
}

}  // namespace

// A rank's slab of a z axis (cfd/navier_stokes/decomposition.hpp; the MPI runs are in tests/mpi): the sliced axis
// keeps the whole axis's metrics at its indices, ghosts included, so stencils at a cut see the interior values.
namespace {

TEST(NavierStokesDecomposition, SliceKeepsTheWholeAxisMetricsAtACut) {
  const Axis whole = Axis::stretched(
      StretchedAxis{.lo = -2, .hi = 3, .box_lo = -0.5, .box_hi = 0.5, .h = 0.1, .max_ratio = 1.08, .multiple_of = 8},
      false);
  const Slab sl{8, 16, true, true};
  const Axis a = whole.slice(sl);
  EXPECT_EQ(a.n, 16);
  EXPECT_FALSE(a.periodic);
  EXPECT_TRUE(a.lower_face_unknown());
  EXPECT_FALSE(a.owns_upper_face());
  for (int I = 0; I <= a.n + 1; ++I) {
    EXPECT_EQ(a.xc[std::size_t(I)], whole.xc[std::size_t(I + 8)]) << I;
    EXPECT_EQ(a.df[std::size_t(I)], whole.df[std::size_t(I + 8)]) << I;
    EXPECT_EQ(a.dv[std::size_t(I)], whole.dv[std::size_t(I + 8)]) << I;  // no half cell at a cut
  }
  EXPECT_EQ(a.lo, whole.xf[9]);
  EXPECT_EQ(a.hi, whole.xf[25]);
  // Without cuts (one rank) the slice is the axis itself; a slab outside the axis is refused; a slice is not
  // coarsened (the multigrid slices the coarsened whole axis).
  EXPECT_EQ(whole.slice(Slab{0, whole.n, false, false}).n, whole.n);
  EXPECT_THROW(whole.slice(Slab{whole.n - 4, 8, true, false}), std::invalid_argument);
  EXPECT_THROW(a.coarsened(), std::invalid_argument);
  // The first rank of a walled axis: a wall below (face 1 is a boundary face), a cut above.
  const Axis first = whole.slice(Slab{0, 16, false, true});
  EXPECT_FALSE(first.lower_face_unknown());
  EXPECT_FALSE(first.owns_upper_face());
  EXPECT_EQ(first.dv[1], whole.dv[1]);  // the wall's half cell
}

TEST(NavierStokesDecomposition, InterfacesMustBeTheCutsOfTheSlab) {
  const Grid g(Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 8, false), Axis::uniform(0, 1, 32, true));
  const Boundaries periodic_z = [] {
    Boundaries b = Boundaries::all(BC::velocity);
    b.face[face(2, 0)].type = b.face[face(2, 1)].type = BC::periodic;
    return b;
  }();
  const Slab middle{8, 8, true, true};
  const Grid part = g.slice_z(middle);
  const Boundaries local = periodic_z.local(middle);
  EXPECT_EQ(local.type(2, 0), BC::interface);
  EXPECT_EQ(local.type(2, 1), BC::interface);
  EXPECT_EQ(local.pressure()[face(2, 0)], ScalarBC::interface);
  EXPECT_NO_THROW(local.check(part));
  EXPECT_THROW(periodic_z.check(part), std::invalid_argument);  // the cut is not an interface
  EXPECT_THROW(local.check(g), std::invalid_argument);          // an interface where the grid has no cut
  // One rank: Decomposition's slabs cover the axis in whole blocks; the multigrid's block for 2 and 3 ranks.
  const Decomposition one;
  EXPECT_FALSE(one.distributed());
  const auto slabs = one.slabs(32, 8, true);
  ASSERT_EQ(slabs.size(), 1u);
  EXPECT_EQ(slabs[0].n, 32);
  EXPECT_FALSE(slabs[0].cut_lo || slabs[0].cut_hi);
  EXPECT_THROW(one.slabs(30, 8, true), std::invalid_argument);  // not whole blocks
  EXPECT_EQ(one.sum(2.5), 2.5);
  EXPECT_EQ(one.max(-1.0), -1.0);
}

// The block of planes: the largest z coarsening factor whose blocks share out within 10 %. A 96-plane axis (factors
// 2 ... 32): on 2 ranks 32 would give 3 blocks, 2 + 1 (one rank twice the other's work), so 16; on 3 ranks 32.
TEST(NavierStokesDecomposition, SlabBlocksShareOutEvenly) {
  const Axis a = Axis::uniform(0, 1, 96, true);
  const Grid cube(a, a, a);
  EXPECT_EQ(Multigrid::z_unit(cube, 2), 16);
  EXPECT_EQ(Multigrid::z_unit(cube, 3), 32);
  EXPECT_EQ(Multigrid::z_unit(cube, 1), 32);
  const Grid odd(a, a, Axis::uniform(0, 1, 45, false));  // z never coarsens: no block to split
  EXPECT_EQ(Multigrid::z_unit(odd, 2), 1);
}

}  // namespace
