// End-to-end tests of `flapstab cfd`: bad input exits with status 2 and writes nothing.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include "common/case_text.hpp"

namespace flapstab {
namespace {

namespace fs = std::filesystem;
using testing::replace;
using testing::valid_case_text;
using testing::write_temp;

struct CfdRunOutput {
  int status;
  std::string out, err;
};

CfdRunOutput flapstab_cfd(const std::string& args) {
  const std::string errfile = write_temp("cfd_stderr.txt", ""), outfile = write_temp("cfd_stdout.txt", "");
  const std::string cmd = std::string(FLAPSTAB_BINARY) + " cfd " + args + " > " + outfile + " 2> " + errfile;
  const int rc = std::system(cmd.c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(outfile), slurp(errfile)};
}

std::string with_cfd(const std::string& keys) {
  return replace(replace(valid_case_text(), "model = \"quasi-steady\"", "model = \"cfd\""), "[trim]\n",
                 "[aero.cfd]\n" + keys + "\n[trim]\n");
}

struct Bad {
  const char* label;
  const char* keys;
  const char* key;
};

class CfdCliBadInput : public ::testing::TestWithParam<Bad> {};

TEST_P(CfdCliBadInput, ExitsWithTwoAndWritesNothing) {
  const Bad b = GetParam();
  const std::string path = write_temp(std::string("cfdcli_") + b.label + ".toml", with_cfd(b.keys));
  const fs::path dir = fs::path(path).parent_path() / (std::string("cfdcli_dir_") + b.label);
  fs::remove_all(dir);
  for (const char* extra : {"", " --dry-run", " --restart"}) {
    const CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string() + extra);
    EXPECT_EQ(r.status, 2) << b.label << extra << ": " << r.err;
    EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(b.key), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir)) << b.label << extra;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Inputs, CfdCliBadInput,
    ::testing::Values(Bad{"unknown_key", "cells_per_cord = 8", "aero.cfd.cells_per_cord"},
                      Bad{"bad_type", "cycles = \"two\"", "aero.cfd.cycles"},
                      Bad{"out_of_range", "stretch_ratio = 1.5", "aero.cfd.stretch_ratio"},
                      Bad{"under_resolved", "cells_per_chord = 2", "aero.cfd.cells_per_chord"},
                      Bad{"outside_domain", "fine_margin_R = 0\nabove_R = 0", "aero.cfd.above_R"}),
    [](const ::testing::TestParamInfo<Bad>& i) { return std::string(i.param.label); });

TEST(CfdCli, RestartWithoutCheckpointsIsBadInput) {
  const std::string path = write_temp("cfdcli_restart.toml", with_cfd("cells_per_chord = 4"));
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_restart_dir";
  fs::remove_all(dir);
  const CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string() + " --restart");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("--restart"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir));
}

const char* tiny =
    "cells_per_chord = 4\nfine_margin_R = 0.4\nupstream_R = 0\ndownstream_R = 0\nlateral_R = 0\nabove_R = 0\n"
    "below_R = 0.5\nbody_divisions = 6\nwing_span_stations = 12\nwing_chord_divisions = 4\nthreads = 1\n";

TEST(CfdCli, DryRunPrintsTheEstimateAndWritesNothing) {
  const std::string path = write_temp("cfdcli_dry.toml", with_cfd(std::string(tiny) + "steps_per_cycle = 400\n"));
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_dry_dir";
  fs::remove_all(dir);
  const CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string() + " --dry-run");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir));
  for (const char* k : {"Re = ", "cells", "bytes per cell", "400 steps", "estimate (timed on the first 2 steps)"})
    EXPECT_NE(r.err.find(k), std::string::npos) << k << "\n" << r.err;
  EXPECT_NE(r.out.find("nothing written"), std::string::npos) << r.out;
}

// A fixed step far too large for the wings (the tip crosses many cells per step): the run stops with status 3,
// the message names the step and time, and the initial checkpoint stays for a restart with a smaller step.
TEST(CfdCli, DivergenceExitsWithThreeAndKeepsTheCheckpoint) {
  const std::string path = write_temp("cfdcli_diverge.toml", with_cfd(std::string(tiny) + "steps_per_cycle = 4\n"));
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_diverge_dir";
  fs::remove_all(dir);
  const CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string() + " -q");
  EXPECT_EQ(r.status, 3) << r.err;
  EXPECT_NE(r.err.find("diverged at step 1 (t = "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("aero.cfd.steps_per_cycle"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(dir / "checkpoints" / "checkpoint_000000000.h5"));
  EXPECT_FALSE(fs::exists(dir / "run.json"));
}

// A gentle wingbeat (stroke +-10 deg, pitch 90 +- 10 deg) at Re = 20 on a tiny grid: one wingbeat, then
// --restart --cycles 2 runs on from the final checkpoint to the end of the second.
TEST(CfdCli, RunThenRestartForMoreCycles) {
  std::string text = with_cfd(std::string(tiny) + "steps_per_cycle = 60\nreynolds = 20\nfields_per_cycle = 2\n"
                                                   "surfaces_per_cycle = 2\ncheckpoints_per_cycle = 2\n");
  text = replace(replace(text, "cos_deg = [-60.0]", "cos_deg = [-10.0]"), "sin_deg = [-55.0]", "sin_deg = [-10.0]");
  const std::string path = write_temp("cfdcli_run.toml", text);
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_run_dir";
  fs::remove_all(dir);
  CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* k : {"step      60", "t/T   1.0000", "cycle   1", "Poisson", "ETA"})
    EXPECT_NE(r.err.find(k), std::string::npos) << k << "\n" << r.err;
  for (const char* f : {"forces.csv", "run.json", "fields/fields.xmf", "fields/fields_000030.h5", "surfaces/surfaces.pvd",
                        "surfaces/surfaces_left_000060.vtp", "checkpoints/checkpoint_000000060.h5",
                        "checkpoints/checkpoint_000000030.h5"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "checkpoints/checkpoint_000000000.h5"));  // only the last two are kept
  {
    // The left and right wings' mean side forces over the first wingbeat mirror each other.
    std::ifstream in1(dir / "run.json");
    const nlohmann::json j1 = nlohmann::json::parse(in1);
    const double yr = j1["mean_loads_last_cycle"]["right"]["force_N"][1];
    const double yl = j1["mean_loads_last_cycle"]["left"]["force_N"][1];
    EXPECT_GT(std::abs(yr), 0.0);
    EXPECT_NEAR(yl, -yr, 0.02 * std::abs(yr));
  }
  r = flapstab_cfd(path + " -o " + dir.string() + " --restart --cycles 2");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("restarting from"), std::string::npos) << r.err;
  std::ifstream in(dir / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["time"]["steps"], 120);
  EXPECT_EQ(j["time"]["restart_step"], 60);
  EXPECT_EQ(j["time"]["cycles"], 2);
  EXPECT_EQ(j["command"], "cfd");
  const auto& total = j["mean_loads_last_cycle"]["total"]["force_N"];
  ASSERT_EQ(total.size(), 3u);
  EXPECT_NEAR(double(j["mean_loads_last_cycle"]["from_s"]), 0.5 * double(j["time"]["end_time_s"]), 1e-12);
  for (int a = 0; a < 3; ++a) EXPECT_TRUE(std::isfinite(double(total[std::size_t(a)])));
  std::ifstream csv(dir / "forces.csv");
  int rows = 0;
  for (std::string line; std::getline(csv, line);)
    if (!line.empty() && line[0] != '#' && line.rfind("time_s", 0) != 0) ++rows;
  EXPECT_EQ(rows, 120);
}

TEST(CfdCli, HelpDescribesTheOptions) {
  const CfdRunOutput r = flapstab_cfd("--help");
  EXPECT_EQ(r.status, 0);
  for (const char* k : {"--restart", "--cycles", "--dry-run", "-o,--output", "forces.csv"})
    EXPECT_NE(r.out.find(k), std::string::npos) << k << "\n" << r.out;
}


// The CFD stability chain refuses, before any CFD run, a derivative step whose load changes (predicted by the
// quasi-steady model) the periodic convergence cannot resolve: exit 2, the key and the numbers, nothing written.
TEST(CfdCli, DerivativeStepTooSmallForTheCfdRunsIsBadInput) {
  std::string text = with_cfd(std::string(tiny) + "steps_per_cycle = 60\nperturbation_tolerance = 0.005\n");
  text += "\n[derivatives]\nrelative_step = 0.001\n";
  const std::string path = write_temp("cfdcli_step.toml", text);
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_step_dir";
  fs::remove_all(dir);
  const std::string errfile = write_temp("cfd_step_stderr.txt", "");
  const int rc = std::system((std::string(FLAPSTAB_BINARY) + " derivatives " + path + " -o " + dir.string() + " 2> " +
                              errfile).c_str());
  std::ifstream in(errfile);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string err = ss.str();
  EXPECT_EQ(WEXITSTATUS(rc), 2) << err;
  EXPECT_NE(err.find("derivatives.relative_step"), std::string::npos) << err;
  EXPECT_NE(err.find("10 x aero.cfd.perturbation_tolerance"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir / "cfd_runs")) << err;
}

}  // namespace
}  // namespace flapstab
