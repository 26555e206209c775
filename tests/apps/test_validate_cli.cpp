// End-to-end tests of `flapstab validate hovering-2d`: a short run writes its set of files with the published
// comparison's inputs; bad input exits with status 2 and writes nothing.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include "common/run_cli.hpp"

namespace {

namespace fs = std::filesystem;

using flapstab::testing::CliOutput;
using flapstab::testing::slurp;

CliOutput validate(const std::string& args) {
  return flapstab::testing::run_flapstab("validate hovering-2d " + args, "validate");
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::path(::testing::TempDir()) / name;
  fs::remove_all(d);
  return d;
}

// A coarse run of a twentieth of a period: the files, their header and the normalisation it states (the
// reference data's README: L_max ~ 3.02, D_max ~ 3.74 per unit span).
TEST(ValidateCli, ShortHovering2dRunWritesItsFiles) {
  const fs::path d = fresh_dir("validate_short");
  const CliOutput r = validate("--cells-per-chord 8 --cycles 0.05 -o " + d.string());
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_TRUE(fs::exists(d / "history.csv"));
  ASSERT_TRUE(fs::exists(d / "summary.json"));
  const std::string csv = slurp(d / "history.csv");
  EXPECT_EQ(csv.substr(0, csv.find('\n')),
            "t,t_over_T,x_centre_c,alpha_deg,lift_per_span,drag_per_span,C_L,C_D,lift_per_span_surface,"
            "drag_per_span_surface,cfl");
  const auto j = nlohmann::json::parse(slurp(d / "summary.json"));
  EXPECT_NEAR(j["normalisation"]["lift_max_per_span"].get<double>(), 3.02, 0.01);
  EXPECT_NEAR(j["normalisation"]["drag_max_per_span"].get<double>(), 3.74, 0.01);
  EXPECT_EQ(j["grid"]["cells"][2].get<int>(), 2);
  EXPECT_LT(j["grid"]["spanwise_deviation_over_U_max"].get<double>(), 1e-3);
  EXPECT_FALSE(j.contains("comparison"));  // fewer than 4 cycles
  if (std::system("command -v gnuplot > /dev/null 2>&1") == 0) {  // figures need gnuplot (absent: reported, not fatal)
    EXPECT_TRUE(fs::exists(d / "lift.svg")) << r.err;
    EXPECT_TRUE(fs::exists(d / "drag.svg")) << r.err;
  }
  EXPECT_NE(j["verdict"].get<std::string>().find("not compared"), std::string::npos);
}

TEST(ValidateCli, MissingReferenceFileExits2AndWritesNothing) {
  const fs::path refs = fresh_dir("validate_refs");
  fs::create_directories(refs);
  std::ofstream(refs / "CL_Wang2004_experiment.dat") << "0.1 0.2\n0.2 0.3\n";
  const fs::path d = fresh_dir("validate_none");
  const CliOutput r =
      validate("--cells-per-chord 8 --cycles 0.05 --reference " + refs.string() + " -o " + d.string());
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("CD_Wang2004_experiment.dat"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d));
}

TEST(ValidateCli, OutOfRangeOptionExits2) {
  const fs::path d = fresh_dir("validate_range");
  const CliOutput r = validate("--cells-per-chord 2 -o " + d.string());
  EXPECT_EQ(r.status, 2);
  EXPECT_FALSE(fs::exists(d));
}

}  // namespace
