// End-to-end tests of `flapstab grid-convergence`: three synthetic CFD results whose derivatives follow an exact
// power law in the grid spacing give back its order and limit; two grids use the assumed order; mixed or
// incomplete inputs exit with status 2 and write nothing.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include "common/run_cli.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using flapstab::testing::CliOutput;
using flapstab::testing::slurp;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::path(::testing::TempDir()) / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

CliOutput grid_convergence(const std::string& args) {
  return flapstab::testing::run_flapstab("grid-convergence " + args, "gc");
}

// A longitudinal CFD result at `cells` cells per chord: Xu = -0.3 + 0.8 h^2, Mq = -1 - 0.5 h (h = c / cells, in
// chords), Zw = 0.1 exactly; standard errors 1e-4.
fs::path result(const fs::path& dir, const std::string& name, double cells, const std::string& insect = "moth",
                double chord = 0.01) {
  const double h = 1.0 / cells;
  json nd, se;
  for (const char* r : {"X", "Y", "Z", "L", "M", "N"})
    for (const char* c : {"u", "v", "w", "p", "q", "r"}) nd[std::string(r) + c] = 0.0;
  nd["Xu"] = -0.3 + 0.8 * h * h;
  nd["Mq"] = -1.0 - 0.5 * h;
  nd["Zw"] = 0.1;
  for (const char* k : {"Xu", "Xw", "Xq", "Zu", "Zw", "Zq", "Mu", "Mw", "Mq"}) se[k] = 1e-4;
  const json j = {{"insect", insect},
                  {"derivatives",
                   {{"planes", {{"longitudinal", true}, {"lateral", false}}},
                    {"nondimensional", nd},
                    {"standard_error_nondimensional", se},
                    {"reference", {{"U_m_s", 2.0}, {"c_m", chord}, {"S_t_m2", 1e-3}, {"rho_kg_m3", 1.225},
                                   {"frequency_hz", 26.0}}}}},
                  {"cfd", {{"grid", {{"fine_spacing_m", chord * h}, {"cells_per_mean_chord", cells},
                                     {"reynolds", 1000.0}}}}}};
  const fs::path p = dir / name;
  std::ofstream(p) << j.dump(1);
  return p;
}

const json* entry(const json& j, const std::string& name) {
  for (const auto& e : j.at("derivatives"))
    if (e.at("derivative") == name) return &e;
  return nullptr;
}

TEST(GridConvergenceCli, ThreeGridsGiveTheOrderAndLimitOfEachDerivative) {
  const fs::path d = fresh_dir("gc_three");
  const fs::path a = result(d, "a.json", 8), b = result(d, "b.json", 12), c = result(d, "c.json", 18);
  const CliOutput r = grid_convergence(c.string() + " " + a.string() + " " + b.string() + " -o " + (d / "out").string());
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_TRUE(fs::exists(d / "out" / "grid_convergence.md"));
  const json j = json::parse(slurp(d / "out" / "grid_convergence.json"));
  EXPECT_EQ(j.at("derivatives").size(), 9u);  // the longitudinal plane only
  const json* xu = entry(j, "Xu");
  ASSERT_NE(xu, nullptr);
  EXPECT_EQ(xu->at("convergence"), "monotone");
  EXPECT_NEAR(xu->at("order").get<double>(), 2.0, 1e-6);
  EXPECT_NEAR(xu->at("extrapolated").get<double>(), -0.3, 1e-9);
  EXPECT_NEAR(xu->at("values_finest_first")[0].get<double>(), -0.3 + 0.8 / 324, 1e-12);
  const json* mq = entry(j, "Mq");
  EXPECT_NEAR(mq->at("order").get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(mq->at("extrapolated").get<double>(), -1.0, 1e-9);
  EXPECT_EQ(entry(j, "Zw")->at("convergence"), "unchanged");
  // Xu's change between the finest pair (0.8 (1/144 - 1/324) = 3.1e-3) is beyond twice the runs' combined
  // standard error (2.8e-4); Mq's (0.5 (1/12 - 1/18) = 1.4e-2) too.
  EXPECT_FALSE(xu->at("within_run_scatter").get<bool>());
  EXPECT_NE(r.out.find("| Xu |"), std::string::npos);
}

TEST(GridConvergenceCli, TwoGridsUseTheAssumedOrder) {
  const fs::path d = fresh_dir("gc_two");
  const fs::path a = result(d, "a.json", 8), b = result(d, "b.json", 16);
  const CliOutput r = grid_convergence(a.string() + " " + b.string() + " --order 1 --json " + (d / "gc.json").string() +
                                    " -q");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(r.out.empty());
  const json j = json::parse(slurp(d / "gc.json"));
  const json* mq = entry(j, "Mq");
  EXPECT_TRUE(mq->at("order_assumed").get<bool>());
  EXPECT_NEAR(mq->at("extrapolated").get<double>(), -1.0, 1e-9);  // exact for a first-order error
  // GCI = 3 |f2 - f1| / |f1| / (r - 1) with r = 2.
  const double f1 = -1 - 0.5 / 16, f2 = -1 - 0.5 / 8;
  EXPECT_NEAR(mq->at("gci_fine").get<double>(), 3 * std::abs((f2 - f1) / f1), 1e-9);
}

TEST(GridConvergenceCli, MixedOrIncompleteInputsExit2AndWriteNothing) {
  const fs::path d = fresh_dir("gc_bad");
  const fs::path a = result(d, "a.json", 8), b = result(d, "b.json", 12);
  const fs::path other = result(d, "other.json", 12, "fly");
  const fs::path chord = result(d, "chord.json", 12, "moth", 0.02);
  const fs::path same = result(d, "same.json", 8);
  const fs::path broken = d / "broken.json";
  std::ofstream(broken) << "{\"insect\": \"moth\"}";
  const fs::path out = d / "out";
  struct Bad {
    std::string args, says;
  };
  for (const Bad& x : {Bad{a.string(), "two or three"}, Bad{a.string() + " " + other.string(), "insect"},
                       Bad{a.string() + " " + chord.string(), "derivatives.reference.c_m"},
                       Bad{a.string() + " " + same.string(), "cfd.grid.fine_spacing_m"},
                       Bad{a.string() + " " + broken.string(), "'cfd'"},
                       Bad{a.string() + " " + b.string() + " --order 0", "--order"},
                       Bad{a.string() + " " + d.string(), "holds none of"}}) {
    const CliOutput r = grid_convergence(x.args + " -o " + out.string());
    EXPECT_EQ(r.status, 2) << x.args << "\n" << r.err;
    EXPECT_NE(r.err.find(x.says), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << x.args;
  }
}

}  // namespace
