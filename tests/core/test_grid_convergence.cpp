// Richardson extrapolation and the grid-convergence index (core/grid_convergence.hpp).
#include <array>
#include <cmath>
#include <gtest/gtest.h>

#include "core/errors.hpp"
#include "core/grid_convergence.hpp"

namespace flapstab {
namespace {

// The worked example of Celik, Ghia, Roache, Freitas, Coleman & Raad 2008, J Fluids Eng 130:078001, Table 1,
// column phi = dimensionless reattachment length: N = 18 000, 8 000, 4 500 cells (2-D: r21 = 1.5, r32 = 1.333),
// phi = 6.063, 5.972, 5.863; published p = 1.53, phi_ext21 = 6.1685, e_a21 = 1.5 %, e_ext21 = 1.7 %,
// GCI_fine21 = 2.2 %. Tolerances: half a unit of the published last digit.
TEST(GridConvergence, ReproducesTheWorkedExampleOfCelikEtAl2008) {
  const double h1 = std::sqrt(1.0 / 18000), h2 = std::sqrt(1.0 / 8000), h3 = std::sqrt(1.0 / 4500);
  const GridConvergence g = grid_convergence({{h3, 5.863}, {h1, 6.063}, {h2, 5.972}});  // any order
  EXPECT_EQ(g.kind, GridConvergence::Kind::monotone);
  EXPECT_FALSE(g.order_assumed);
  EXPECT_NEAR(g.order, 1.53, 0.005);
  EXPECT_NEAR(g.extrapolated, 6.1685, 0.0005);
  EXPECT_NEAR(g.relative_error, 0.015, 0.0005);
  EXPECT_NEAR(g.extrapolated_error, 0.017, 0.0005);
  EXPECT_NEAR(g.gci_fine, 0.022, 0.0005);
  EXPECT_DOUBLE_EQ(g.safety_factor, 1.25);
}

// f(h) = f0 + a h^p exactly: the order and the limit are recovered, also with unequal refinement ratios (where the
// fixed point's q(p) term is not zero).
TEST(GridConvergence, RecoversTheOrderAndLimitOfAnExactPowerLaw) {
  for (const double p : {1.0, 2.0, 1.4})
    for (const auto& h : {std::array<double, 3>{1.0, 1.5, 2.25}, std::array<double, 3>{1.0, 2.0, 2.5}}) {
      std::vector<GridValue> v;
      for (double x : h) v.push_back({x, 3.0 - 0.4 * std::pow(x, p)});
      const GridConvergence g = grid_convergence(v);
      EXPECT_EQ(g.kind, GridConvergence::Kind::monotone);
      EXPECT_NEAR(g.order, p, 1e-9) << "p " << p << " h2 " << h[1];
      EXPECT_NEAR(g.extrapolated, 3.0, 1e-9);
      EXPECT_NEAR(g.extrapolated_error, std::abs((3.0 - v[0].value) / 3.0), 1e-9);
    }
}

TEST(GridConvergence, TwoGridsUseTheAssumedOrderAndSafetyFactorThree) {
  // f = 1 + 0.5 h, h = 1, 2: with p = 1 the extrapolation is exact; GCI = 3 |0.5 / 1.5| / (2 - 1) = 1.
  const GridConvergence g = grid_convergence({{1.0, 1.5}, {2.0, 2.0}}, 1.0);
  EXPECT_EQ(g.kind, GridConvergence::Kind::two_grids);
  EXPECT_TRUE(g.order_assumed);
  EXPECT_NEAR(g.extrapolated, 1.0, 1e-12);
  EXPECT_NEAR(g.gci_fine, 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(g.safety_factor, 3.0);
  // With p = 2 the same pair extrapolates less far: (4 x 1.5 - 2) / 3.
  EXPECT_NEAR(grid_convergence({{1.0, 1.5}, {2.0, 2.0}}, 2.0).extrapolated, 4.0 / 3.0, 1e-12);
}

TEST(GridConvergence, OscillatoryAndDivergingSequencesAreNamedAndFallBackToTwoGrids) {
  const GridConvergence osc = grid_convergence({{1.0, 1.0}, {1.5, 1.1}, {2.25, 0.95}}, 1.0);
  EXPECT_EQ(osc.kind, GridConvergence::Kind::oscillatory);
  EXPECT_TRUE(osc.order_assumed);
  EXPECT_NEAR(osc.gci_fine, 3 * 0.1 / 0.5, 1e-12);
  EXPECT_FALSE(osc.note.empty());
  // The change grows as the grid is refined: 0.02 between the coarse pair, 0.1 between the fine pair.
  const GridConvergence div = grid_convergence({{1.0, 1.0}, {2.0, 1.1}, {4.0, 1.12}}, 1.0);
  EXPECT_EQ(div.kind, GridConvergence::Kind::diverging);
  EXPECT_TRUE(div.order_assumed);
  // Order 1 with unequal ratios (r21 = 2, r32 = 1.1) shrinks the coarse pair's change below the fine pair's and is
  // still convergence, not divergence.
  const GridConvergence slow = grid_convergence({{1.0, 2.0 + 1.0}, {2.0, 2.0 + 2.0}, {2.2, 2.0 + 2.2}});
  EXPECT_EQ(slow.kind, GridConvergence::Kind::monotone);
  EXPECT_NEAR(slow.order, 1.0, 1e-9);
  EXPECT_NEAR(slow.extrapolated, 2.0, 1e-9);
}

TEST(GridConvergence, UnchangedValuesHaveNoError) {
  const GridConvergence g = grid_convergence({{1.0, 0.3}, {2.0, 0.3}, {3.0, 0.3}});
  EXPECT_EQ(g.kind, GridConvergence::Kind::unchanged);
  EXPECT_EQ(g.gci_fine, 0.0);
  EXPECT_EQ(g.extrapolated, 0.3);
}

TEST(GridConvergence, RefusesTooFewGridsSharedSpacingsAndBadValues) {
  EXPECT_THROW(grid_convergence({{1.0, 1.0}}), SolveError);
  EXPECT_THROW(grid_convergence({{1.0, 1.0}, {2.0, 1.0}, {3.0, 1.0}, {4.0, 1.0}}), SolveError);
  EXPECT_THROW(grid_convergence({{1.0, 1.0}, {1.0, 2.0}}), SolveError);
  EXPECT_THROW(grid_convergence({{0.0, 1.0}, {1.0, 2.0}}), SolveError);
  EXPECT_THROW(grid_convergence({{1.0, NAN}, {2.0, 2.0}}), SolveError);
  EXPECT_THROW(grid_convergence({{1.0, 1.0}, {2.0, 2.0}}, 0.0), SolveError);
}

}  // namespace
}  // namespace flapstab
