// Grid of the Navier-Stokes solver: uniform and stretched axes (spacing, ratio, bounds, cell-count rounding),
// ghost-cell metrics, coarsening, input validation, and the box boundary-condition checks.
#include <gtest/gtest.h>
#include <cmath>
#include "cfd/navier_stokes/boundary.hpp"
#include "cfd/navier_stokes/grid.hpp"

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
