// The CFD stability study's plan checks that need no CFD run (apps/cfd_study.hpp).
#include <gtest/gtest.h>
#include <string>

#include "apps/cfd_study.hpp"
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "core/case_file.hpp"
#include "core/derivative_table.hpp"
#include "stability/lti.hpp"
#include "trim/trim.hpp"

namespace flapstab {
namespace {

// A steady rate turns the body q T per wingbeat: the shipped fruit fly's pitch-rate step (relative_rate_step 0.03
// of U/c, with U = 2 Phi n r2 at its quasi-steady trim, about 1.31 m/s, and c = 0.8 mm: 49.07 rad/s with the
// narrow-based planform of the CFD case) at 218 Hz is 12.9 deg per wingbeat, above the 5 deg the plan accepts;
// 0.03 x 5 / 12.9 = 0.0116 gives 5 deg.
TEST(CfdStudyPlan, WarnsWhenTheRateStepTurnsTheBodyMoreThanFiveDegreesPerWingbeat) {
  const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/fruitfly_cfd.toml");
  Case qc = c;
  qc.aero.model = "quasi-steady";
  const auto model = make_aero_model(qc);
  const TrimResult t = trim_hover(qc, *model);
  ASSERT_TRUE(t.converged);
  const ReferenceQuantities ref = reference_quantities(c.insect, t.kinematics, c.fluid);
  ASSERT_EQ(c.derivatives.relative_rate_step, 0.03);
  const double q = c.derivatives.relative_rate_step * ref.U / ref.c;
  EXPECT_NEAR(q, 49.07, 0.01);
  ASSERT_DOUBLE_EQ(t.kinematics.frequency_hz, 218.0);
  const auto w = rate_step_warning(c, q, 218.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("turns the body 12.9 deg per wingbeat"), std::string::npos) << *w;
  EXPECT_NE(w->find("relative_rate_step = 0.0116"), std::string::npos) << *w;
  // 5 deg per wingbeat and below: no warning.
  EXPECT_FALSE(rate_step_warning(c, 5.0 * 3.14159265358979323846 / 180 * 218.0 * 0.999, 218.0).has_value());
}

// The shipped CFD stability cases pass the checks made before any CFD run (the quasi-steady trim converges, every
// derivative step moves the loads by at least 10 x perturbation_tolerance), so that `flapstab derivatives` and
// `analyze` on them start their runs. (A model change once left the fruit fly's rate step just under the bound:
// 0.0196 against 0.02 of the weight.)
TEST(CfdStudyPlan, ShippedCfdCasesPassThePreRunChecks) {
  for (const char* name : {"fruitfly_cfd.toml", "hawkmoth_cfd.toml", "bumblebee_cfd.toml"}) {
    const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/" + name);
    Case qc = c;
    qc.aero.model = "quasi-steady";
    const auto model = make_aero_model(qc);
    TrimResult t;
    DerivativeResult d;
    EXPECT_NO_THROW(quasi_steady_start(c, *model, t, d)) << name;
  }
}

// The split of the velocity derivatives by mechanism pairs each column's two runs as the table does and scales the
// partition's central differences like the table: with a reference speed U, force scale F and moment scale F c, a
// partition difference of dP N between the +h and -h runs is dP / (2 h) N per m/s, dP U / (2 h F) non-dimensional.
// Rate runs carry no partition, runs of other kinematics are not paired, and a column with one run missing is left out.
TEST(CfdStudySplit, PairsTheColumnsRunsAndScalesLikeTheTable) {
  DerivativeResult d;
  d.velocity_step = 0.1;
  d.rate_step = 2.0;
  auto& ref = d.table.reference;
  ref.rho = 1.2;
  ref.U = 2.0;
  ref.S_t = 0.5;
  ref.c = 0.25;  // force scale 0.5 rho U^2 S_t = 1.2 N, moment scale 0.3 N m
  d.table.nd(0, 0) = -0.7;
  auto run = [](double u, double w, double q, double x_pressure, double x_vortex, double m_kinematic) {
    ns::CfdRunRecord r;
    r.motion.velocity = Vec3(u, 0, w);
    r.motion.rate = Vec3(0, q, 0);
    r.cycles.resize(3);
    ns::PartitionMeans p;
    p.components = {0, 4};  // Fx, My
    p.values.assign(2, {});
    p.values[0][ns::PartitionMeans::pressure] = x_pressure;
    p.values[0][ns::PartitionMeans::vortex] = x_vortex;
    p.values[1][ns::PartitionMeans::kinematic] = m_kinematic;
    p.values[1][ns::PartitionMeans::centripetal] = 0.25 * m_kinematic;
    if (q == 0) r.partition = p;
    return r;
  };
  std::vector<ns::CfdRunRecord> runs = {run(0.1, 0, 0, -0.30, -0.20, 0.06), run(-0.1, 0, 0, 0.18, 0.10, 0.02),
                                        run(0, 0, 2.0, 9, 9, 9), run(0, 0, -2.0, 9, 9, 9), run(0, 0.1, 0, 1, 1, 1)};
  ns::CfdRunRecord other = run(-0.1, 0, 0, 5, 5, 5);
  other.other_kinematics = true;  // a trim iterate's run at the same speed: not the column's
  runs.push_back(other);
  const std::vector<MechanismSplit> s = split_by_mechanism(d, runs, {0, 2, 4});
  ASSERT_EQ(s.size(), 2u);  // X_u and M_u; the w column lacks its -w run, the q column is not split
  EXPECT_EQ(s[0].row, 0);
  EXPECT_EQ(s[0].column, 0);
  EXPECT_EQ(s[0].total, -0.7);
  EXPECT_NEAR(s[0].pressure, (-0.30 - 0.18) / 0.2 * 2.0 / 1.2, 1e-12);  // -4.0
  EXPECT_NEAR(s[0].vortex, (-0.20 - 0.10) / 0.2 * 2.0 / 1.2, 1e-12);    // -2.5
  EXPECT_NEAR(s[0].sum(), s[0].vortex, 1e-12);
  EXPECT_EQ(s[1].row, 4);
  EXPECT_NEAR(s[1].kinematic, (0.06 - 0.02) / 0.2 * 2.0 / 0.3, 1e-12);
  EXPECT_NEAR(s[1].added_mass(), 0.75 * s[1].kinematic, 1e-12);
}

// The forced pitch oscillation's fits enter the longitudinal system where the table's q column and gravity's theta
// column are (docs/theory/cfd-stability.md, "Forced pitch oscillation"): rate fits equal to the table's q column
// (dimensional: times (1/2 rho U^2 S_t) c/U, and c more for M) with no attitude derivative give the table's system
// and modes; an attitude derivative M_theta adds M_theta+ / Iy+ at A(q, theta), X_theta+ / m+ at A(u, theta).
TEST(CfdStudyPitchOscillation, ItsColumnsEnterTheLongitudinalSystem) {
  const DerivativeTable t =
      read_derivative_table(std::string(FLAPSTAB_SOURCE_DIR) + "/data/examples/derivative_table_bumblebee.toml");
  ASSERT_TRUE(t.has_longitudinal);
  const ReferenceQuantities& ref = t.reference;
  ns::PitchOscillationResult r;
  r.spec.amplitude = 0.035;
  r.spec.period_wingbeats = 10;
  r.omega = 2 * 3.14159265358979 * ref.frequency / 10;
  for (int i = 0; i < 6; ++i) {
    const double scale = i < 3 ? ref.force_scale() : ref.moment_scale();
    r.fit[std::size_t(i)].rate = t.nd(i, 4) * scale * ref.time_scale();
    r.last_period[std::size_t(i)] = r.fit[std::size_t(i)];
  }
  const PitchOscillationStudy same = pitch_oscillation_study(r, t);
  EXPECT_NEAR(same.omega_nd, r.omega * ref.time_scale(), 1e-15);
  EXPECT_NEAR(same.rate_nd[4], t.nd(4, 4), 1e-12 * std::abs(t.nd(4, 4)));
  ASSERT_TRUE(same.modes && same.modes_steady_rate);
  const Eigen::MatrixXd A0 = same.modes_steady_rate->system_matrix_nd;
  EXPECT_LT((same.modes->system_matrix_nd - A0).norm(), 1e-12 * A0.norm());
  ASSERT_EQ(same.modes->modes.size(), same.modes_steady_rate->modes.size());
  EXPECT_NEAR(same.modes->modes[0].eigenvalue_nd.real(), same.modes_steady_rate->modes[0].eigenvalue_nd.real(), 1e-12);
  r.fit[4].theta = 0.3 * ref.moment_scale();  // M_theta+ = 0.3 per rad
  r.fit[0].theta = -0.2 * ref.force_scale();  // X_theta+ = -0.2 per rad
  const PitchOscillationStudy lag = pitch_oscillation_study(r, t);
  const NonDimensionalParameters q = nondimensional_parameters(t);
  EXPECT_NEAR(lag.theta_nd[4], 0.3, 1e-12);
  EXPECT_NEAR(lag.modes->system_matrix_nd(2, 3) - A0(2, 3), 0.3 / q.Iyy, 1e-12 * (1 + 0.3 / q.Iyy));
  EXPECT_NEAR(lag.modes->system_matrix_nd(0, 3) - A0(0, 3), -0.2 / q.m, 1e-12 * (1 + 0.2 / q.m));
  EXPECT_EQ(lag.modes->system_matrix_nd(1, 3), A0(1, 3));
}

}  // namespace
}  // namespace flapstab
