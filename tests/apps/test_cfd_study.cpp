// The CFD stability study's plan checks that need no CFD run (apps/cfd_study.hpp).
#include <gtest/gtest.h>
#include <string>

#include "apps/cfd_study.hpp"
#include "core/case_file.hpp"

namespace flapstab {
namespace {

// A steady rate turns the body q T per wingbeat: the shipped fruit fly's pitch-rate step 0.05 U/c (U = 2 Phi n r2
// = 1.312 m/s at its quasi-steady trim, c = 0.8 mm: 82.0 rad/s) at 218 Hz is 82.0 / 218 rad = 21.6 deg per
// wingbeat, above the 5 deg the plan accepts; the step that gives 5 deg is 0.05 x 5 / 21.6 = 0.0116.
TEST(CfdStudyPlan, WarnsWhenTheRateStepTurnsTheBodyMoreThanFiveDegreesPerWingbeat) {
  const Case c = load_case(std::string(FLAPSTAB_SOURCE_DIR) + "/data/cases/fruitfly_cfd.toml");
  const double q = 0.05 * 1.31225068217043 / 0.8e-3;
  const auto w = rate_step_warning(c, q, 218.0);
  ASSERT_TRUE(w.has_value());
  EXPECT_NE(w->find("turns the body 21.6 deg per wingbeat"), std::string::npos) << *w;
  EXPECT_NE(w->find("relative_rate_step = 0.0116"), std::string::npos) << *w;
  // 5 deg per wingbeat and below: no warning.
  EXPECT_FALSE(rate_step_warning(c, 5.0 * 3.14159265358979323846 / 180 * 218.0 * 0.999, 218.0).has_value());
}

}  // namespace
}  // namespace flapstab
