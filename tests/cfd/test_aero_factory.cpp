// Tests for cfd/aero_factory: the case's [aero] selects the model; an unknown model is an input error.
#include <gtest/gtest.h>
#include "cfd/aero_factory.hpp"
#include "common/case_text.hpp"
#include "core/errors.hpp"

namespace flapstab {
namespace {

TEST(AeroFactory, SelectsTheQuasiSteadyCoefficientSet) {
  Case c = load_case(testing::write_temp("f.toml", testing::valid_case_text()));
  EXPECT_EQ(make_aero_model(c)->name(), "quasi-steady (robofly)");
  c.aero.quasi_steady.coefficients = "berman-wang";
  EXPECT_EQ(make_aero_model(c)->name(), "quasi-steady (berman-wang)");
  EXPECT_TRUE(make_aero_model(c)->is_instantaneous());
}

TEST(AeroFactory, SelectsTheNavierStokesModel) {
  Case c = load_case(testing::write_temp("f2.toml", testing::valid_case_text()));
  c.aero.model = "cfd";
  const auto m = make_aero_model(c);
  EXPECT_EQ(m->name(), "navier-stokes-ib");
  EXPECT_FALSE(m->is_instantaneous());
}

TEST(AeroFactory, UnknownModelIsAnInputError) {
  Case c = load_case(testing::write_temp("f3.toml", testing::valid_case_text()));
  c.aero.model = "panel";
  try {
    make_aero_model(c);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), "aero.model");
  }
}

}  // namespace
}  // namespace flapstab
