// Tests of trim/refine: Broyden's method on an "expensive" model from the trim of a cheap one.
#include <gtest/gtest.h>
#include <cmath>
#include <memory>
#include <string>

#include "cfd/aero_factory.hpp"
#include "common/case_text.hpp"
#include "trim/refine.hpp"

namespace flapstab {
namespace {

// The test moth with the Robofly coefficients (cheap) and with Berman & Wang's (expensive), and the cheap trim.
struct TwoModels {
  Case cheap, fine;
  std::unique_ptr<AeroModel> cheap_model, fine_model;
  TrimResult start;
  explicit TwoModels(const std::string& name)
      : cheap(load_case(testing::write_temp(name, testing::valid_case_text()))), fine(cheap) {
    fine.aero.quasi_steady.coefficients = "berman-wang";
    cheap_model = make_aero_model(cheap);
    fine_model = make_aero_model(fine);
    start = trim_hover(cheap, *cheap_model);
  }
};

// Two quasi-steady models that differ as a CFD model differs from the quasi-steady one (here: the Robofly
// coefficients as the cheap model, Berman & Wang's as the expensive one). From the cheap trim, Broyden's method with
// the cheap Jacobian reaches the expensive model's trim: residuals below 1e-6 of the weight within 8 runs, and the
// parameters agree with Ipopt's trim of the expensive model (the same equations, 3 parameters for 3 equations: a
// unique root) to 1e-4 deg.
TEST(RefineTrim, BroydenFromTheCheapTrimReachesTheExpensiveModelsTrim) {
  const TwoModels m("refine_cheap.toml");
  const Case& fine = m.fine;
  const auto& fine_model = m.fine_model;
  const auto& cheap_model = m.cheap_model;
  const TrimResult& start = m.start;
  ASSERT_TRUE(start.converged);
  const TrimResult direct = trim_hover(fine, *fine_model);
  ASSERT_TRUE(direct.converged);
  const TrimResult r = refine_trim(fine, *fine_model, *cheap_model, start, RefineSettings{1e-6, 8});
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_LE(r.model_runs, 9);
  EXPECT_LT(r.relative_force_residual, 2e-6);
  ASSERT_EQ(r.parameters.size(), direct.parameters.size());
  for (std::size_t i = 0; i < r.parameters.size(); ++i) {
    EXPECT_NEAR(r.parameters[i].value, direct.parameters[i].value, 1e-4) << r.parameters[i].name;
    EXPECT_EQ(r.parameters[i].initial, start.parameters[i].value);
  }
  // The models differ enough that the start is not already a trim of the expensive model.
  double moved = 0;
  for (std::size_t i = 0; i < r.parameters.size(); ++i) moved = std::max(moved, std::abs(r.parameters[i].value - start.parameters[i].value));
  EXPECT_GT(moved, 0.1);
}

// No iterations allowed: the start evaluated on the expensive model, reported as not converged with its residual.
TEST(RefineTrim, ZeroIterationsReportsTheStartsResidual) {
  const TwoModels m("refine_zero.toml");
  const TrimResult r = refine_trim(m.fine, *m.fine_model, *m.cheap_model, m.start, RefineSettings{1e-6, 0});
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.model_runs, 1);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_GT(r.relative_force_residual, 1e-3);
}

}  // namespace
}  // namespace flapstab
