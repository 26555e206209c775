// Tests of the LTI system builders (stability/lti.cpp) against the non-dimensional forms of docs/derivative-table.md (Sun & Xiong 2005) and Etkin's equations.
#include "stability/lti.hpp"

#include <gtest/gtest.h>

#include "stability/modes.hpp"
#include "stability_fixtures.hpp"

using namespace flapstab;
using namespace flapstab::test;

namespace {

std::vector<std::complex<double>> eigenvalues(const Eigen::MatrixXd& A) {
  Eigen::EigenSolver<Eigen::MatrixXd> es(A, false);
  std::vector<std::complex<double>> v;
  for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) v.push_back(es.eigenvalues()(i));
  return v;
}

}  // namespace

TEST(NonDimensional, Parameters) {
  const DerivativeTable t = hover_like_table();
  const auto nd = nondimensional_parameters(t);
  const double half_rho_S = 0.5 * 1.225 * 1e-4;
  EXPECT_DOUBLE_EQ(nd.m, 1.75e-4 / (half_rho_S * 0.004));
  EXPECT_DOUBLE_EQ(nd.Iyy, 4.0e-9 / (half_rho_S * 0.004 * 0.004 * 0.004));
  EXPECT_DOUBLE_EQ(nd.g, 9.81 * 0.004 / (4.5 * 4.5));
  EXPECT_DOUBLE_EQ(nd.time_scale_s, 0.004 / 4.5);
}

// The longitudinal and lateral matrices of docs/derivative-table.md, written out entry by entry from the formula.
TEST(Systems, MatchArchitectureFormulaEntryByEntry) {
  const DerivativeTable t = hover_like_table();
  const auto nd = nondimensional_parameters(t);
  const auto lon = longitudinal_system(t);
  ASSERT_EQ(lon.state_order, (std::vector<std::string>{"u", "w", "q", "theta"}));
  const double m = nd.m, Iy = nd.Iyy, g = nd.g;
  const double expected_lon[4][4] = {
      {t.at("Xu") / m, t.at("Xw") / m, t.at("Xq") / m, -g},
      {t.at("Zu") / m, t.at("Zw") / m, t.at("Zq") / m, 0},
      {t.at("Mu") / Iy, t.at("Mw") / Iy, t.at("Mq") / Iy, 0},
      {0, 0, 1, 0}};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_DOUBLE_EQ(lon.A(i, j), expected_lon[i][j]) << i << "," << j;

  ASSERT_EQ(t.mass.Ixz, 0.0);
  const auto lat = lateral_system(t);
  ASSERT_EQ(lat.state_order, (std::vector<std::string>{"v", "p", "r", "phi"}));
  const double Ix = nd.Ixx, Iz = nd.Izz;
  const double expected_lat[4][4] = {
      {t.at("Yv") / m, t.at("Yp") / m, t.at("Yr") / m, g},
      {t.at("Lv") / Ix, t.at("Lp") / Ix, t.at("Lr") / Ix, 0},
      {t.at("Nv") / Iz, t.at("Np") / Iz, t.at("Nr") / Iz, 0},
      {0, 1, 0, 0}};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_DOUBLE_EQ(lat.A(i, j), expected_lat[i][j]) << i << "," << j;
}

// With Ixz != 0 the rows satisfy Etkin's moment equations Ix p' - Ixz r' = L, Iz r' - Ixz p' = N
// (Etkin & Reid 1996, Dynamics of Flight, 3rd ed., ch. 4), checked by multiplying back;
// tolerance 1e-13 relative (rounding only).
TEST(Systems, LateralWithIxzSatisfiesEtkinMomentEquations) {
  DerivativeTable t = hover_like_table();
  t.mass.Ixz = -0.6 * std::sqrt(t.mass.Ixx * t.mass.Izz);
  const auto nd = nondimensional_parameters(t);
  const auto A = lateral_system(t).A;
  const std::array<std::string, 3> cols = {"v", "p", "r"};
  for (int j = 0; j < 3; ++j) {
    const double L = t.at(std::string("L") + cols[j]), N = t.at(std::string("N") + cols[j]);
    EXPECT_NEAR(nd.Ixx * A(1, j) - nd.Ixz * A(2, j), L, 1e-13 * std::abs(L));
    EXPECT_NEAR(nd.Izz * A(2, j) - nd.Ixz * A(1, j), N, 1e-13 * std::abs(N));
  }
  EXPECT_EQ(A(1, 3), 0.0);
  EXPECT_EQ(A(2, 3), 0.0);
  EXPECT_EQ(A(0, 3), nd.g);
  EXPECT_EQ(A(3, 1), 1.0);
}

TEST(Systems, CoupledWithoutCrossTermsInterleavesTheTwo) {
  for (double ixz : {0.0, 0.4}) {
    DerivativeTable t = hover_like_table();
    t.mass.Ixz = ixz * std::sqrt(t.mass.Ixx * t.mass.Izz);
    const auto lon = longitudinal_system(t).A, lat = lateral_system(t).A;
    const auto six = coupled_system(t);
    ASSERT_EQ(six.state_order, (std::vector<std::string>{"u", "v", "w", "p", "q", "r", "phi", "theta"}));
    const int lon_idx[4] = {0, 2, 4, 7}, lat_idx[4] = {1, 3, 5, 6};  // positions in the 6DoF order
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        EXPECT_DOUBLE_EQ(six.A(lon_idx[i], lon_idx[j]), lon(i, j));
        EXPECT_DOUBLE_EQ(six.A(lat_idx[i], lat_idx[j]), lat(i, j));
        EXPECT_EQ(six.A(lon_idx[i], lat_idx[j]), 0.0);
        EXPECT_EQ(six.A(lat_idx[i], lon_idx[j]), 0.0);
      }
    // The 6DoF spectrum is the union of the two (1e-10 relative: each is a well-conditioned 4x4).
    auto both = eigenvalues(lon);
    const auto l2 = eigenvalues(lat);
    both.insert(both.end(), l2.begin(), l2.end());
    EXPECT_LT(max_relative_mismatch(eigenvalues(six.A), both), 1e-10);
  }
}

TEST(Systems, CoupledUsesCrossDerivatives) {
  DerivativeTable t = hover_like_table();
  t.at("Xv") = 0.3;
  t.at("Mp") = -0.7;
  t.at("Lu") = 0.2;
  t.has_coupling = true;
  const auto nd = nondimensional_parameters(t);
  const auto A = coupled_system(t).A;
  EXPECT_DOUBLE_EQ(A(0, 1), 0.3 / nd.m);     // u' row, v column
  EXPECT_DOUBLE_EQ(A(4, 3), -0.7 / nd.Iyy);  // q' row, p column
  EXPECT_DOUBLE_EQ(A(3, 0), 0.2 / nd.Ixx);   // p' row, u column (Ixz = 0)
}

// Eigenvalues (Eigen::EigenSolver, inside analyse_modes) against the roots of the characteristic
// polynomial computed independently (Faddeev-LeVerrier coefficients, Durand-Kerner roots, long
// double): 1e-10 relative, for the three systems of several tables (synthetic hover-like and
// pseudo-random, with and without Ixz and cross-coupling).
TEST(Systems, EigenvaluesAgreeWithIndependentCharacteristicPolynomialRoots) {
  std::vector<DerivativeTable> tables = {hover_like_table()};
  for (unsigned seed : {1u, 2u, 3u, 4u}) tables.push_back(random_table(seed, seed % 2 == 0, seed % 2 ? 0.3 : -0.5));
  for (const auto& t : tables)
    for (const auto& sys : {longitudinal_system(t), lateral_system(t), coupled_system(t)}) {
      const auto analysis = analyse_modes(sys, t.reference);
      std::vector<std::complex<double>> lam;
      for (const auto& m : analysis.modes) {
        lam.push_back(m.eigenvalue_nd);
        if (m.conjugate_pair) lam.push_back(std::conj(m.eigenvalue_nd));
      }
      ASSERT_EQ(lam.size(), std::size_t(sys.A.rows()));
      const auto ref = polynomial_roots(characteristic_polynomial(sys.A));
      EXPECT_LT(max_relative_mismatch(lam, ref), 1e-10) << sys.name << " of " << t.source;
    }
}

// A spectrum known in closed form: with Xw = Xq = Mw = 0 and Zu = Zq = 0 the vertical motion
// decouples and lambda = Zw/m+ exactly; the u-q-theta block's cubic is det(lambda I - B).
TEST(Systems, DecoupledHeaveRootIsZwOverMass) {
  DerivativeTable t = hover_like_table();
  t.at("Xw") = t.at("Xq") = t.at("Mw") = t.at("Zu") = t.at("Zq") = 0;
  const auto nd = nondimensional_parameters(t);
  const auto a = analyse_modes(longitudinal_system(t), t.reference);
  const double heave = t.at("Zw") / nd.m;
  bool found = false;
  for (const auto& m : a.modes)
    if (!m.conjugate_pair && std::abs(m.eigenvalue_nd.real() - heave) <= 1e-12 * std::abs(heave)) {
      found = true;
      EXPECT_EQ(m.dominant_states, std::vector<std::string>{"w"});
    }
  EXPECT_TRUE(found);
}
