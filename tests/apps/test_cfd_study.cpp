// The CFD stability study's plan checks that need no CFD run (apps/cfd_study.hpp).
#include <gtest/gtest.h>
#include <string>

#include "apps/cfd_study.hpp"
#include "cfd/aero_factory.hpp"
#include "cfd/derivatives.hpp"
#include "core/case_file.hpp"
#include "trim/trim.hpp"

namespace flapstab {
namespace {

// A steady rate turns the body q T per wingbeat: the shipped fruit fly's pitch-rate step (relative_rate_step 0.025
// of U/c, with U = 2 Phi n r2 at its quasi-steady trim, about 1.31 m/s, and c = 0.8 mm: 40.89 rad/s with the
// narrow-based planform of the CFD case, 41.0 with the elliptic one) at 218 Hz is 10.75 deg per wingbeat, above the
// 5 deg the plan accepts; 0.025 x 5 / 10.75 = 0.0116 gives 5 deg.
TEST(CfdStudyPlan, WarnsWhenTheRateStepTurnsTheBodyMoreThanFiveDegreesPerWingbeat) {
  const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/fruitfly_cfd.toml");
  Case qc = c;
  qc.aero.model = "quasi-steady";
  const auto model = make_aero_model(qc);
  const TrimResult t = trim_hover(qc, *model);
  ASSERT_TRUE(t.converged);
  const ReferenceQuantities ref = reference_quantities(c.insect, t.kinematics, c.fluid);
  ASSERT_EQ(c.derivatives.relative_rate_step, 0.025);
  const double q = c.derivatives.relative_rate_step * ref.U / ref.c;
  EXPECT_NEAR(q, 40.89, 0.01);
  ASSERT_DOUBLE_EQ(t.kinematics.frequency_hz, 218.0);
  const auto w = rate_step_warning(c, q, 218.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("turns the body 10.7 deg per wingbeat"), std::string::npos) << *w;
  EXPECT_NE(w->find("relative_rate_step = 0.0116"), std::string::npos) << *w;
  // 5 deg per wingbeat and below: no warning.
  EXPECT_FALSE(rate_step_warning(c, 5.0 * 3.14159265358979323846 / 180 * 218.0 * 0.999, 218.0).has_value());
}

}  // namespace
}  // namespace flapstab
