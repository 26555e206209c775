// Phase-resolved derivatives: their cycle mean about rest is the averaged derivative table, and A(t) is the
// Jacobian of the free system (checked against directional differences of the full right-hand side).
#include <gtest/gtest.h>

#include "cfd/derivatives.hpp"
#include "cfd/phase_derivatives.hpp"
#include "common/test_insect.hpp"
#include "core/errors.hpp"

namespace flapstab {
namespace {

QuasiSteadyModel model() { return QuasiSteadyModel(QuasiSteadyOptions{}); }

// About hover at rest (zero orbit), the phase-resolved wrench derivatives at t_k = k T / N averaged over
// the N phases are exactly what cycle_averaged_derivatives differences (the same N samples, steps and
// model): equal to rounding (1e-9 relative to the largest entry).
TEST(PhaseDerivatives, MeanAboutRestIsTheAveragedTable) {
  const Insect insect = testing::test_insect();
  const Kinematics kin = testing::harmonic_kinematics();
  const QuasiSteadyModel qs = model();
  const FluidProperties fluid;
  const DerivativeResult avg = cycle_averaged_derivatives(qs, insect, kin, fluid, 0.01);
  const InstantaneousAero aero(qs, insect, kin);
  const int N = qs.options().samples_per_cycle;
  const PhaseDerivatives pd = phase_resolved_derivatives(
      aero, std::vector<BodyStateVector>(std::size_t(N), BodyStateVector::Zero()), avg.table.reference, 0.01);
  ASSERT_EQ(int(pd.samples.size()), N);
  const double scale = avg.table.nd.cwiseAbs().maxCoeff();
  EXPECT_LT((pd.mean_wrench_nd() - avg.table.nd).cwiseAbs().maxCoeff(), 1e-9 * scale);
  EXPECT_LT((pd.mean_wrench_si() - avg.si).cwiseAbs().maxCoeff(), 1e-9 * avg.si.cwiseAbs().maxCoeff());
}

// A(t) about a moving state: A dx against (f(x + e dx) - f(x - e dx)) / 2e of the full nonlinear
// right-hand side (aerodynamics and inertia together). With a relative derivative step of 1e-5 both are
// central differences with O(h^2) ~ 1e-10 truncation: agreement to 1e-6 of |f'| checks the assembly
// (inverse mass matrix times the wrench derivatives plus the inertial Jacobian) and the state order.
TEST(PhaseDerivatives, SystemMatrixIsTheJacobianOfTheFreeSystem) {
  const Insect insect = testing::test_insect();
  const Kinematics kin = testing::harmonic_kinematics();
  const QuasiSteadyModel qs = model();
  const InstantaneousAero aero(qs, insect, kin);
  const ReferenceQuantities ref = reference_quantities(insect, kin, FluidProperties{});
  std::vector<BodyStateVector> orbit;
  for (int k = 0; k < 8; ++k) {
    BodyStateVector x = BodyStateVector::Zero();
    x.segment<3>(3) = Vec3(0.1, -0.05, 0.07) * ref.U * std::cos(k);
    x.segment<3>(6) = Vec3(-0.02, 0.04, 0.03) * ref.U / ref.c * std::sin(k + 1);
    x(9) = 0.1 * std::sin(k);
    x(10) = -0.2 + 0.05 * k;
    orbit.push_back(x);
  }
  const PhaseDerivatives pd = phase_resolved_derivatives(aero, orbit, ref, 1e-5);
  Eigen::Matrix<double, 8, 1> dx;
  dx << ref.U, -0.5 * ref.U, 0.7 * ref.U, 0.3 * ref.U / ref.c, -0.4 * ref.U / ref.c, 0.2 * ref.U / ref.c, 0.5, -0.6;
  for (const PhaseSample& s : pd.samples) {
    const double e = 1e-6;
    BodyStateVector xp = s.state, xm = s.state;
    for (int j = 0; j < 8; ++j) {
      xp(linear_state_index[j]) += e * dx(j);
      xm(linear_state_index[j]) -= e * dx(j);
    }
    const BodyStateVector fd = (free_flight_derivative(aero, s.time, xp) - free_flight_derivative(aero, s.time, xm)) / (2 * e);
    const Eigen::Matrix<double, 8, 1> lin = s.system_si * dx;
    EXPECT_LT((lin - fd.segment<8>(3)).norm(), 1e-6 * fd.segment<8>(3).norm()) << "t = " << s.time;
  }
}

// Left-right symmetric insect about a symmetric state: longitudinal and lateral states decouple at
// every phase (cross blocks zero to rounding).
TEST(PhaseDerivatives, SymmetricHoverDecouples) {
  const Insect insect = testing::test_insect();
  const Kinematics kin = testing::harmonic_kinematics();
  const QuasiSteadyModel qs = model();
  const InstantaneousAero aero(qs, insect, kin);
  const ReferenceQuantities ref = reference_quantities(insect, kin, FluidProperties{});
  std::vector<BodyStateVector> orbit(16, BodyStateVector::Zero());
  for (std::size_t k = 0; k < orbit.size(); ++k) {
    orbit[k](3) = 0.05 * ref.U * std::sin(double(k));
    orbit[k](7) = 0.1 * ref.U / ref.c * std::cos(double(k));
  }
  const PhaseDerivatives pd = phase_resolved_derivatives(aero, orbit, ref, 0.01);
  const std::vector<int> lon{0, 2, 4, 7}, lat{1, 3, 5, 6};
  for (const PhaseSample& s : pd.samples) {
    const double scale = s.system_si.cwiseAbs().maxCoeff();
    for (int i : lon)
      for (int j : lat) {
        EXPECT_LT(std::abs(s.system_si(i, j)), 1e-9 * scale);
        EXPECT_LT(std::abs(s.system_si(j, i)), 1e-9 * scale);
      }
  }
}

}  // namespace
}  // namespace flapstab
