// End-to-end tests of `flapstab cfd`: bad input exits with status 2 and writes nothing.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <sstream>
#include "cfd/navier_stokes/observers.hpp"
#include "common/case_text.hpp"
#include "core/types.hpp"

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

// Runs `prefix flapstab args` (prefix: an environment or a launcher), capturing its status and output.
CfdRunOutput run_flapstab(const std::string& prefix, const std::string& args) {
  const std::string errfile = write_temp("cfd_stderr.txt", ""), outfile = write_temp("cfd_stdout.txt", "");
  const std::string cmd = prefix + FLAPSTAB_BINARY + " " + args + " > " + outfile + " 2> " + errfile;
  const int rc = std::system(cmd.c_str());
  auto slurp = [](const std::string& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(outfile), slurp(errfile)};
}

// `prefix flapstab cfd args`.
CfdRunOutput run_cfd_command_line(const std::string& prefix, const std::string& args) {
  return run_flapstab(prefix, "cfd " + args);
}

CfdRunOutput flapstab_cfd(const std::string& args) { return run_cfd_command_line("", args); }

std::string with_cfd(const std::string& keys) {
  return replace(replace(testing::valid_cfd_case_text(), "model = \"quasi-steady\"", "model = \"cfd\""), "[trim]\n",
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

#if defined(FLAPSTAB_MPIEXEC) && defined(FLAPSTAB_HAVE_MPI)
std::string mpiexec(int n) {
  const char* flags = std::getenv("FLAPSTAB_TEST_MPI_FLAGS");
  return std::string(FLAPSTAB_MPIEXEC) + (flags ? flags : " --allow-run-as-root --oversubscribe --bind-to none") +
         " -n " + std::to_string(n) + " ";
}

CfdRunOutput flapstab_cfd_ranks(int n, const std::string& args) {
  return run_cfd_command_line("OMP_NUM_THREADS=1 " + mpiexec(n), args);
}

int occurrences(const std::string& s, const std::string& what) {
  int n = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

// `mpiexec -n 2 flapstab cfd` runs one flow over the two processes (the grid in z slabs) and writes the run of one
// process: the same forces.csv (to the pressure solves' tolerance), the same files, one report; its checkpoint
// restarts on three ranks and on one process.
TEST(CfdCli, OneFlowOverRanksUnderMpiexecIsTheOneProcessRun) {
  const std::string keys = std::string(tiny) + "steps_per_cycle = 80\ncheckpoints_per_cycle = 8\n";
  const std::string path = write_temp("cfdcli_ranks.toml", with_cfd(keys));
  const fs::path base = fs::path(path).parent_path();
  const fs::path one = base / "cfdcli_ranks_one", two = base / "cfdcli_ranks_two";
  fs::remove_all(one);
  fs::remove_all(two);
  const CfdRunOutput a = flapstab_cfd(path + " -o " + one.string() + " --steps 8");
  ASSERT_EQ(a.status, 0) << a.err;
  const CfdRunOutput b = flapstab_cfd_ranks(2, path + " -o " + two.string() + " --steps 8");
  ASSERT_EQ(b.status, 0) << b.err;
  // rank 0 speaks for both: one report, one log
  EXPECT_EQ(occurrences(b.out, "wrote "), 1) << b.out;
  EXPECT_EQ(occurrences(b.err, "flapstab cfd: "), 1) << b.err;
  // forces.csv: the pressure solves stop at their tolerance (1e-3 of the divergence), and round-off can decide one
  // more iteration on one side: the runs then differ by about 1e-9 of the loads (measured; to round-off, 1e-15, when
  // the solves are converged: tests/mpi). A defect of the decomposition (a missing exchange) changes them at O(1).
  auto compare = [&](const fs::path& x, const fs::path& y, long rows) {
    const int parts = 3;  // body and two wings
    ns::ForcesCsv rx("", parts), ry("", parts);
    rx.keep_earlier((x / "forces.csv").string(), rows);  // every row of steps 1 ... rows, or InputError
    ry.keep_earlier((y / "forces.csv").string(), rows);
    ASSERT_EQ(rx.earlier().size(), std::size_t(rows));
    ASSERT_EQ(ry.earlier().size(), std::size_t(rows));
    double diff = 0, scale = 0;
    for (std::size_t n = 0; n < std::size_t(rows); ++n)
      for (int i = 0; i < parts; ++i) {
        const Wrench a = rx.earlier()[n].part[i].wrench(), b = ry.earlier()[n].part[i].wrench();
        diff = std::max(diff, (a.force - b.force).cwiseAbs().maxCoeff());
        scale = std::max(scale, b.force.cwiseAbs().maxCoeff());
      }
    EXPECT_GT(scale, 0);
    EXPECT_LE(diff, 1e-6 * scale) << x << " against " << y;
    std::printf("[ forces.csv ] %s against %s: max difference %.3g N of %.3g N\n", x.filename().c_str(),
                y.filename().c_str(), diff, scale);
  };
  compare(two, one, 8);
  const auto json = nlohmann::json::parse(std::ifstream(two / "run.json"));
  EXPECT_EQ(json["timings"]["ranks"], 2);
  EXPECT_EQ(json["grid"]["cells"], nlohmann::json::parse(std::ifstream(one / "run.json"))["grid"]["cells"]);
  for (const char* f : {"forces.svg", "fields/fields.xmf", "surfaces", "checkpoints/checkpoint_000000008.h5"})
    EXPECT_TRUE(fs::exists(two / f)) << f;
  // The checkpoint of two ranks goes on on three, and on one process; both end as the one process's run does.
  const fs::path three = base / "cfdcli_ranks_three", back = base / "cfdcli_ranks_back";
  fs::remove_all(three);
  fs::remove_all(back);
  fs::copy(two, three, fs::copy_options::recursive);
  fs::copy(two, back, fs::copy_options::recursive);
  const CfdRunOutput c = flapstab_cfd_ranks(3, path + " -o " + three.string() + " --steps 4 --restart");
  ASSERT_EQ(c.status, 0) << c.err;
  EXPECT_NE(c.err.find("restarting from"), std::string::npos) << c.err;
  const CfdRunOutput d = flapstab_cfd(path + " -o " + back.string() + " --steps 4 --restart");
  ASSERT_EQ(d.status, 0) << d.err;
  ASSERT_EQ(flapstab_cfd(path + " -o " + one.string() + " --steps 4 --restart").status, 0);
  compare(three, one, 12);
  compare(back, one, 12);
}

// steps.csv of flapstab fly: its header and rows.
struct StepsTable {
  std::vector<std::string> names;
  std::vector<std::vector<double>> rows;
};
StepsTable read_steps(const fs::path& file) {
  std::ifstream in(file);
  StepsTable t;
  std::string line, cell;
  std::getline(in, line);
  for (std::stringstream ss(line); std::getline(ss, cell, ',');) t.names.push_back(cell);
  while (std::getline(in, line)) {
    std::vector<double> row;
    for (std::stringstream ss(line); std::getline(ss, cell, ',');) row.push_back(std::stod(cell));
    t.rows.push_back(row);
  }
  return t;
}

// Two flights' steps.csv alike: the same steps, and every state and load within `tol` of the largest value of its
// kind (positions, velocities, rates, angles, forces, moments, power, commands: a lateral load that is zero to
// round-off is measured against the lift, not against itself).
void expect_same_flight(const fs::path& a, const fs::path& b, double tol) {
  const StepsTable x = read_steps(a / "steps.csv"), y = read_steps(b / "steps.csv");
  ASSERT_EQ(x.names, y.names);
  ASSERT_EQ(x.rows.size(), y.rows.size()) << a << " " << b;
  ASSERT_GT(x.rows.size(), 10u);
  const std::vector<std::vector<std::string>> kinds = {
      {"step"}, {"x_m", "y_m", "z_m"}, {"u_m_s", "v_m_s", "w_m_s"}, {"p_rad_s", "q_rad_s", "r_rad_s"},
      {"phi_rad", "theta_rad", "psi_rad"}, {"X_N", "Y_N", "Z_N"}, {"L_N_m", "M_N_m", "N_N_m"}, {"power_W"}};
  auto column = [&](const std::string& n) {
    return int(std::find(x.names.begin(), x.names.end(), n) - x.names.begin());
  };
  for (const auto& kind : kinds) {
    double scale = 0, diff = 0;
    for (const std::string& n : kind) {
      const int j = column(n);
      ASSERT_LT(j, int(x.names.size())) << n;
      for (std::size_t r = 0; r < x.rows.size(); ++r) {
        scale = std::max(scale, std::abs(x.rows[r][std::size_t(j)]));
        diff = std::max(diff, std::abs(x.rows[r][std::size_t(j)] - y.rows[r][std::size_t(j)]));
      }
    }
    EXPECT_LE(diff, tol * scale) << kind.front() << "...: " << a << " against " << b;
    std::printf("[ steps.csv ] %s...: max difference %.3g of %.3g\n", kind.front().c_str(), diff, scale);
  }
}

// `mpiexec -n N flapstab fly` with the CFD model runs every flow (the hover, the reference and the perturbed flight)
// over the N processes, the grid in z slabs, and writes the one-process flight: the same steps to 1e-6 of each
// kind's largest value (the pressure solves' tolerance decides an iteration here and there: measured 2e-9 of the
// pitch rate, 7e-9 of the loads; a missing plane or a body moved differently on one rank changes them at O(1)).
// Closed loop with a reference flight on two ranks (field files per rank); a flight from rest whose fine box is
// re-planned at once (the flow carried over on rank 0 and scattered), stopped on three ranks and extended on two.
TEST(CfdCli, FreeFlightOverRanksIsTheOneProcessFlight) {
  const std::string keys = std::string(tiny) + "steps_per_cycle = 120\nreynolds = 20\ncycles = 2\nmax_cycles = 2\n"
                                               "trim_iterations = 0\nfield_files = \"per-rank\"\n";
  const std::string closed = with_cfd(keys) +
                             "\n[flight]\ndof = \"longitudinal\"\nsamples_per_wingbeat = 20\n"
                             "[flight.perturbation]\nq_deg_s = 50.0\n[control]\ntype = \"pitch\"\n[control.pitch]\n"
                             "actuator = \"stroke_plane_deg\"\npitch_gain = 2.0\nrate_gain_s = 0.05\n"
                             "pitch_latency_s = 0.005\nrate_latency_s = 0.005\nlimit_deg = 20\n";
  const std::string path = write_temp("cfdcli_fly_ranks.toml", closed);
  const fs::path base = fs::path(path).parent_path();
  const fs::path one = base / "cfdcli_fly_one", two = base / "cfdcli_fly_two";
  fs::remove_all(one);
  fs::remove_all(two);
  // `launcher flapstab fly toml -o dir --wingbeats n` on one thread per process.
  auto fly = [](const std::string& launcher, const std::string& toml, const fs::path& dir, const char* wingbeats) {
    return run_flapstab("OMP_NUM_THREADS=1 " + launcher,
                        "fly " + toml + " -o " + dir.string() + " --wingbeats " + wingbeats);
  };
  const CfdRunOutput a = fly("", path, one, "0.25");
  ASSERT_EQ(a.status, 0) << a.out << a.err;
  const CfdRunOutput b = fly(mpiexec(2), path, two, "0.25");
  ASSERT_EQ(b.status, 0) << b.out << b.err;
  EXPECT_EQ(occurrences(b.out, "free flight of"), 1) << b.out;  // rank 0 speaks for both
  EXPECT_NE(b.out.find("every flow over 2 MPI ranks"), std::string::npos) << b.out;
  expect_same_flight(one, two, 1e-6);
  const auto json = nlohmann::json::parse(std::ifstream(two / "run.json"));
  EXPECT_EQ(json["cfd"]["mpi_ranks"], 2);
  int pieces = 0;  // rank 1's own field files
  for (const auto& f : fs::directory_iterator(two / "fields")) pieces += f.path().string().ends_with(".p0001.h5");
  EXPECT_GT(pieces, 0);
  EXPECT_TRUE(fs::exists(two / "reference_checkpoint.h5"));

  const std::string rest = with_cfd(keys) + "\n[flight]\ndof = \"longitudinal\"\nstart = \"rest\"\n"
                                            "samples_per_wingbeat = 20\n[flight.perturbation]\nx_m = 0.05\n";
  const std::string moved = write_temp("cfdcli_fly_ranks_replan.toml", rest);
  const fs::path r1 = base / "cfdcli_fly_replan_one", r3 = base / "cfdcli_fly_replan_three";
  fs::remove_all(r1);
  fs::remove_all(r3);
  const CfdRunOutput c = fly("", moved, r1, "0.2");
  ASSERT_EQ(c.status, 0) << c.out << c.err;
  const CfdRunOutput d = fly(mpiexec(3), moved, r3, "0.1");
  ASSERT_EQ(d.status, 0) << d.out << d.err;
  EXPECT_NE(d.out.find("the fine box re-planned at wingbeat"), std::string::npos) << d.out;
  const CfdRunOutput e = fly(mpiexec(2), moved, r3, "0.2");
  ASSERT_EQ(e.status, 0) << e.out << e.err;
  EXPECT_NE(e.out.find("resumed from"), std::string::npos) << e.out;
  expect_same_flight(r1, r3, 1e-6);
  // Bad input under mpiexec: one message (rank 0's), exit status 2, nothing written.
  const fs::path bad_dir = base / "cfdcli_fly_ranks_bad";
  fs::remove_all(bad_dir);
  const CfdRunOutput bad = run_flapstab(
      "OMP_NUM_THREADS=1 " + mpiexec(2),
      "fly " + write_temp("cfdcli_fly_ranks_bad.toml", replace(rest, "cells_per_chord", "cells_per_cord")) + " -o " +
          bad_dir.string());
  EXPECT_EQ(bad.status, 2) << bad.err;
  EXPECT_EQ(occurrences(bad.err, "flapstab: error"), 1) << bad.err;
  EXPECT_NE(bad.err.find("aero.cfd.cells_per_cord"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(bad_dir));
}

// Force partitioning does not run over ranks yet: refused under mpiexec as bad input, before anything is written.
TEST(CfdCli, ForcePartitioningOverRanksIsRefused) {
  const std::string path = write_temp("cfdcli_ranks_fpm.toml",
                                      with_cfd(std::string(tiny) + "[aero.cfd.fpm]\nenabled = true\n"));
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_ranks_fpm";
  fs::remove_all(dir);
  const CfdRunOutput r = flapstab_cfd_ranks(2, path + " -o " + dir.string());
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("aero.cfd.fpm.enabled"), std::string::npos) << r.err;
  EXPECT_EQ(occurrences(r.err, "flapstab: error"), 1) << r.err;  // rank 0's message only
  EXPECT_FALSE(fs::exists(dir));
}

// More ranks than the grid's z planes allow (each slab at least 5 planes for the immersed boundary's window, in whole
// blocks of the multigrid's alignment): bad input naming the rank count it takes, before anything is written.
TEST(CfdCli, MoreRanksThanTheGridTakesAreBadInput) {
  const std::string path = write_temp("cfdcli_ranks_many.toml", with_cfd(tiny));
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_ranks_many";
  fs::remove_all(dir);
  const CfdRunOutput r = flapstab_cfd_ranks(8, path + " -o " + dir.string());
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("'mpiexec -n': 8 ranks cannot share this grid"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("at most"), std::string::npos) << r.err;
  EXPECT_EQ(occurrences(r.err, "flapstab: error"), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir));
}
#endif

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
  // The run ends with its result: one wingbeat from rest is the start-up, and the result says so.
  EXPECT_NE(r.out.find("result over wingbeat 1, the start-up from rest"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("lift / weight = "), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(dir / "forces.svg"));
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
  // The result: wingbeat 2, the start-up wingbeat excluded; lift / weight from the mean F_z and the weight.
  EXPECT_EQ(j["status"], "complete");
  EXPECT_EQ(j["result"]["wingbeat"], 2);
  EXPECT_EQ(j["result"]["includes_startup"], false);
  EXPECT_NEAR(double(j["result"]["lift_over_weight"]),
              -double(j["result"]["force_N"][2]) / double(j["result"]["weight_N"]), 1e-12);
  EXPECT_NE(r.out.find("wingbeat 1, the start-up from rest, excluded"), std::string::npos) << r.out;
  // forces.csv: one header row with units in the names, then one row per step (what pandas.read_csv reads).
  std::ifstream csv(dir / "forces.csv");
  int rows = 0;
  std::string first;
  std::getline(csv, first);
  EXPECT_EQ(first.rfind("time_s,step,phase,", 0), 0u) << first;
  for (std::string line; std::getline(csv, line);) {
    EXPECT_TRUE(!line.empty() && line[0] != '#' && line.rfind("time_s", 0) != 0) << line;
    ++rows;
  }
  EXPECT_EQ(rows, 120);
  // Python's csv module reads it with no options: 120 rows, every column named with its unit.
  if (std::system("python3 --version > /dev/null 2>&1") == 0) {
    const std::string check =
        "python3 -c \"import csv, sys; r = list(csv.DictReader(open(sys.argv[1]))); "
        "assert len(r) == 120, len(r); "
        "assert all(k.endswith(('_N', '_N_m', '_W', '_s')) or k in ('step', 'phase') for k in r[0]), list(r[0]); "
        "assert int(r[-1]['step']) == 120 and abs(float(r[-1]['Fz_N'])) >= 0\" " + (dir / "forces.csv").string();
    EXPECT_EQ(std::system(check.c_str()), 0) << check;
  }
  // A restart with nothing left to do changes nothing.
  const auto stamp = fs::last_write_time(dir / "run.json");
  r = flapstab_cfd(path + " -o " + dir.string() + " --restart --cycles 2");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("nothing to do"), std::string::npos) << r.out;
  EXPECT_EQ(fs::last_write_time(dir / "run.json"), stamp);
  std::ifstream again(dir / "run.json");
  EXPECT_EQ(nlohmann::json::parse(again), j);
}

// The gentle wingbeat of RunThenRestartForMoreCycles with a hind pair of its own (rectangular, 40 mm by 12 mm) hinged
// at `hinge` (m, A axes) and flapping the same angles `phase_deg` ahead.
std::string four_winged(const std::string& keys, const std::string& hinge, const std::string& phase_deg) {
  std::string text = with_cfd(std::string(tiny) + keys);
  text = replace(replace(text, "cos_deg = [-60.0]", "cos_deg = [-10.0]"), "sin_deg = [-55.0]", "sin_deg = [-10.0]");
  text = replace(text, "[kinematics]\n",
                 "[hind_wing]\nlength_m = 0.040\nmean_chord_m = 0.012\nplanform = \"rectangular\"\n"
                 "pitch_axis_chord_fraction = 0.25\nmass_kg = 20e-6\nhinge_m = " + hinge + "\n\n[kinematics]\n");
  return replace(text, "[fluid]\n",
                 "[kinematics.hind]\nphase_deg = " + phase_deg + "\n[kinematics.hind.stroke]\nmean_deg = 0.0\n"
                 "cos_deg = [-10.0]\nsin_deg = [0.0]\n[kinematics.hind.pitch]\nmean_deg = 90.0\ncos_deg = [0.0]\n"
                 "sin_deg = [-10.0]\n\n[fluid]\n");
}

// A four-winged insect: the hind pair ([hind_wing], [kinematics.hind]) is in the CFD geometry as two more parts,
// hind_right and hind_left. Its wing is its own (rectangular, 40 mm by 12 mm), hinged 20 mm behind the fore wing and
// flapping the fore pair's gentle wingbeat in phase, so the two pairs stay about 15 mm apart. One wingbeat on the
// tiny grid: forces.csv, run.json and the surfaces carry all five parts; the five parts' mean loads sum to the total
// (the hind pair's loads are in it), and, the kinematics and geometry being symmetric, the left and right wings'
// mean side forces mirror each other, the fore pair's and the hind pair's (2 %, as RunThenRestartForMoreCycles; measured
// 0.105 % and 0.023 %, 3.6 % and 0.068 % before a face on the mirror plane took both wings' values).
TEST(CfdCli, FourWingedInsectRunsWithFiveParts) {
  // With force partitioning of the four wings (their parts and regions named after them).
  const std::string text = four_winged("steps_per_cycle = 60\nreynolds = 20\nfields_per_cycle = 0\n"
                                       "surfaces_per_cycle = 1\ncheckpoints_per_cycle = 1\n[aero.cfd.fpm]\n"
                                       "samples_per_cycle = 4\ncomponents = [\"Fz\"]\n"
                                       "parts = [\"right\", \"left\", \"hind_right\", \"hind_left\"]\n",
                                       "[-0.014, 0.004, -0.003]", "0.0");
  const std::string path = write_temp("cfdcli_four_wings.toml", text);
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_four_wings_dir";
  fs::remove_all(dir);
  const CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("no forces.svg"), std::string::npos) << r.err;  // the plot reads the five-part rows back
  for (const char* f : {"surfaces/surfaces_hind_right_000060.vtp", "surfaces/surfaces_hind_left_000060.vtp",
                        "surfaces/surfaces_right_000060.vtp", "forces.svg"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;

  // forces.csv: 13 columns per part for the five parts, then the totals.
  std::ifstream csv(dir / "forces.csv");
  std::string header;
  std::getline(csv, header);
  for (const char* col : {"body_Fx_p_N", "left_P_W", "hind_right_Fx_p_N", "hind_right_Mz_v_N_m", "hind_left_P_W",
                          "Fz_N", "wing_power_W"})
    EXPECT_NE(header.find(std::string(",") + col), std::string::npos) << col << " in " << header;
  const auto columns = [](const std::string& line) { return 1 + std::count(line.begin(), line.end(), ','); };
  EXPECT_EQ(columns(header), 3 + 5 * 13 + 7);
  int rows = 0;
  for (std::string line; std::getline(csv, line); ++rows) ASSERT_EQ(columns(line), 3 + 5 * 13 + 7) << line;
  EXPECT_EQ(rows, 60);

  std::ifstream in(dir / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["status"], "complete");
  const auto& mean = j["mean_loads_last_cycle"];
  Vec3 sum = Vec3::Zero(), total = Vec3::Zero();
  double scale = 0;  // N: the parts' loads, against which round-off is measured
  for (const char* part : {"body", "right", "left", "hind_right", "hind_left"}) {
    ASSERT_TRUE(mean.contains(part)) << part;
    ASSERT_TRUE(j["result"]["parts"].contains(part)) << part;
    Vec3 f;
    for (int a = 0; a < 3; ++a) f[a] = double(mean[part]["force_N"][std::size_t(a)]);
    sum += f;
    scale += f.norm();
  }
  for (int a = 0; a < 3; ++a) total[a] = double(mean["total"]["force_N"][std::size_t(a)]);
  EXPECT_LT((sum - total).norm(), 1e-12 * scale) << "parts " << sum.transpose() << ", total " << total.transpose();
  for (const char* pair : {"", "hind_"}) {
    const std::string right = std::string(pair) + "right", left = std::string(pair) + "left";
    const double yr = mean[right]["force_N"][1], yl = mean[left]["force_N"][1];
    std::printf("    %s: mean F_y = %.6g N, %s: %.6g N; |y_l + y_r| / |y_r| = %.3g; mean F_z = %.6g N\n", right.c_str(),
                yr, left.c_str(), yl, std::abs(yl + yr) / std::abs(yr), double(mean[right]["force_N"][2]));
    EXPECT_GT(std::abs(yr), 0.0) << right;
    EXPECT_NEAR(yl, -yr, 0.02 * std::abs(yr)) << right;
  }
  // Force partitioning: the hind wings' rows and regions.
  for (const char* part : {"hind_right", "hind_left"}) EXPECT_TRUE(j["fpm"]["parts"].contains(part)) << part;
  EXPECT_EQ(j["fpm"]["regions"].size(), 1u + 4 * 3);  // the wake and three regions per wing
  std::ifstream fpm(dir / "fpm.csv");
  const std::string fpm_text((std::istreambuf_iterator<char>(fpm)), std::istreambuf_iterator<char>());
  EXPECT_NE(fpm_text.find(",vortex.hind_left.tip"), std::string::npos);
  EXPECT_NE(fpm_text.find(",hind_left,Fz,N,"), std::string::npos);
  // The hind wings carry loads of their own, not a copy of the fore wings' (a smaller wing further back).
  EXPECT_NE(double(mean["hind_right"]["force_N"][2]), double(mean["right"]["force_N"][2]));
}

// Wings that cut through each other are not in what the immersed boundary models: a hind pair hinged 5 mm behind the
// fore pair and flapping half a wingbeat out of phase with it crosses it at the tips (the two strokes swap the
// pairs' order along x while their chords overlap in height). Refused before anything is written, naming the file
// and the hind wing's hinge, with the instant it happens; in phase the same pairs would pass (FourWingedInsect...).
TEST(CfdCli, HindPairCrossingTheForePairIsBadInput) {
  const std::string path = write_temp("cfdcli_crossing_wings.toml",
                                      four_winged("steps_per_cycle = 60\nreynolds = 20\n", "[0.001, 0.004, -0.003]",
                                                  "180.0"));
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_crossing_wings_dir";
  fs::remove_all(dir);
  for (const char* extra : {"", " --dry-run"}) {
    const CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string() + extra);
    EXPECT_EQ(r.status, 2) << extra << ": " << r.err;
    EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("hind_wing.hinge_m"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("hind wing meets the"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir)) << extra;
  }
}

// SIGINT ends a run at the end of the step with a checkpoint and the rows up to it (exit 130); --restart goes on
// from there. --steps N is a smoke run of N steps that can be continued the same way.
TEST(CfdCli, InterruptWritesACheckpointAndRestartContinues) {
  std::string text = with_cfd(std::string(tiny) + "steps_per_cycle = 60\nreynolds = 20\nfields_per_cycle = 0\n"
                                                   "surfaces_per_cycle = 0\ncheckpoints_per_cycle = 1\ncycles = 50\n");
  text = replace(replace(text, "cos_deg = [-60.0]", "cos_deg = [-10.0]"), "sin_deg = [-55.0]", "sin_deg = [-10.0]");
  const std::string path = write_temp("cfdcli_sigint.toml", text);
  const fs::path dir = fs::path(path).parent_path() / "cfdcli_sigint_dir";
  fs::remove_all(dir);
  const std::string err = write_temp("cfd_sigint_stderr.txt", ""), rcfile = write_temp("cfd_sigint_rc.txt", "");
  // Start it, wait for the estimate line (two steps done), start a second run into the same directory (refused:
  // status 2), interrupt the first, record both exit statuses.
  const std::string err2 = write_temp("cfd_second_stderr.txt", "");
  const std::string script =
      std::string(FLAPSTAB_BINARY) + " cfd " + path + " -o " + dir.string() + " 2> " + err + " > /dev/null & pid=$!; " +
      "for i in $(seq 600); do grep -q estimate " + err + " && break; sleep 0.1; done; " + FLAPSTAB_BINARY + " cfd " +
      path + " -o " + dir.string() + " -q 2> " + err2 + "; second=$?; kill -INT $pid; wait $pid; " +
      "echo $? $second > " + rcfile;
  ASSERT_EQ(std::system(("bash -c '" + script + "'").c_str()), 0);
  std::ifstream rc(rcfile), log(err);
  int status = -1, second = -1;
  rc >> status >> second;
  std::ifstream log2(err2);
  std::stringstream ss2;
  ss2 << log2.rdbuf();
  EXPECT_EQ(second, 2) << ss2.str();
  EXPECT_NE(ss2.str().find("another flapstab run is writing into this directory"), std::string::npos) << ss2.str();
  std::stringstream ss;
  ss << log.rdbuf();
  EXPECT_EQ(status, 130) << ss.str();
  EXPECT_NE(ss.str().find("stopped on SIGINT at step"), std::string::npos) << ss.str();
  EXPECT_NE(ss.str().find("--restart"), std::string::npos) << ss.str();
  EXPECT_FALSE(fs::exists(dir / "run.json"));
  // The checkpoint is the step it stopped at, and forces.csv reaches it.
  long newest = -1;
  for (const auto& e : fs::directory_iterator(dir / "checkpoints")) {
    const std::string n = e.path().filename().string();
    if (n.rfind("checkpoint_", 0) == 0 && n.size() == 23) newest = std::max(newest, std::stol(n.substr(11, 9)));
  }
  ASSERT_GT(newest, 1);
  {
    std::ifstream csv(dir / "forces.csv");
    std::string line, last;
    while (std::getline(csv, line)) last = line;
    EXPECT_EQ(last.substr(last.find(',') + 1, last.find(',', last.find(',') + 1) - last.find(',') - 1),
              std::to_string(newest));
  }
  // The same command without --restart (a run from rest into this run's directory) is refused: it would overwrite
  // forces.csv at its first checkpoint, and this run's later checkpoints would outlive its own. Before, it ran, kept
  // the interrupted run's checkpoints and deleted its own; --restart then found forces.csv short of them.
  {
    std::ifstream before(dir / "forces.csv");
    std::stringstream rows;
    rows << before.rdbuf();
    const CfdRunOutput again = flapstab_cfd(path + " -o " + dir.string() + " --steps 2");
    EXPECT_EQ(again.status, 2) << again.out;
    EXPECT_NE(again.err.find(" of an earlier run (the newest at step "), std::string::npos) << again.err;
    EXPECT_NE(again.err.find("--restart to continue that run"), std::string::npos) << again.err;
    std::ifstream after(dir / "forces.csv");
    std::stringstream now;
    now << after.rdbuf();
    EXPECT_EQ(now.str(), rows.str());
  }
  // Continue for two steps (--steps), then check the rows run on without a gap.
  const CfdRunOutput r = flapstab_cfd(path + " -o " + dir.string() + " --restart --steps 2 --cycles 50");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("stopped after --steps 2"), std::string::npos) << r.out;
  std::ifstream csv(dir / "forces.csv");
  std::string line;
  std::getline(csv, line);
  long expect = 1;
  while (std::getline(csv, line)) {
    const auto a = line.find(','), b = line.find(',', a + 1);
    EXPECT_EQ(std::stol(line.substr(a + 1, b - a - 1)), expect) << line;
    ++expect;
  }
  EXPECT_EQ(expect - 1, newest + 2);
  std::ifstream js(dir / "run.json");
  EXPECT_EQ(nlohmann::json::parse(js)["status"], "stopped");
}

// A killed analysis resumed with the same command gives the same results as an uninterrupted one (the CFD stability
// chain, docs/theory/cfd-stability.md): the hover state and every finished run are kept in cfd_runs/ and reused
// bit for bit, a hover or a run killed part way resumes from its last whole wingbeat, the rest is run from the kept
// hover. The tiny moth at Re 20, the longitudinal table (6 runs); killed once in the hover and once in the runs.
// A whole CFD analysis in about 20 s: the tiny grid at Re 20, a short hover, the longitudinal table (6 runs).
std::string small_cfd_analysis() {
  return with_cfd(std::string(tiny) + "steps_per_cycle = 100\nreynolds = 20\ncycles = 2\nhover_tolerance = 0.5\n"
                                       "max_cycles = 3\nperturbation_tolerance = 0.003\ntrim_iterations = 0\n") +
         "\n[derivatives]\nrelative_step = 0.1\ncolumns = \"longitudinal\"\n";
}

TEST(CfdCli, KilledAndResumedAnalyzeGivesTheUninterruptedResults) {
  const std::string text = small_cfd_analysis();
  const std::string path = write_temp("cfdcli_resume.toml", text);
  const fs::path whole = fs::path(path).parent_path() / "cfdcli_resume_whole";
  const fs::path killed = fs::path(path).parent_path() / "cfdcli_resume_killed";
  fs::remove_all(whole);
  fs::remove_all(killed);
  auto run = [&](const fs::path& dir, const std::string& errfile) {
    return std::system((std::string(FLAPSTAB_BINARY) + " analyze " + path + " -o " + dir.string() + " > /dev/null 2> " +
                        errfile).c_str());
  };
  const std::string err_whole = write_temp("cfd_resume_whole.txt", "");
  ASSERT_EQ(WEXITSTATUS(run(whole, err_whole)), 0);
  // Kill the second analysis first in its hover from rest, once it has kept a whole wingbeat (hover.partial.json):
  // the next start resumes the hover from it.
  const std::string err_hover = write_temp("cfd_resume_hover.txt", "");
  const std::string hover_script =
      std::string(FLAPSTAB_BINARY) + " analyze " + path + " -o " + killed.string() + " > /dev/null 2> " + err_hover +
      " & pid=$!; for i in $(seq 3000); do [ -e " + (killed / "cfd_runs" / "hover.partial.json").string() +
      " ] && break; sleep 0.01; done; kill -KILL $pid; wait $pid; true";
  ASSERT_EQ(std::system(("bash -c '" + hover_script + "'").c_str()), 0);
  ASSERT_TRUE(fs::exists(killed / "cfd_runs" / "hover.partial.json"));
  ASSERT_FALSE(fs::exists(killed / "cfd_runs" / "hover.json")) << "the hover finished before it was killed";
  // Then kill the second analysis (SIGKILL: no chance to tidy up) once two perturbed runs are finished and a third has
  // kept a whole wingbeat (run_*.partial.json): the rerun resumes that run from it.
  const std::string err_killed = write_temp("cfd_resume_killed.txt", ""), count = write_temp("cfd_resume_n.txt", "");
  const std::string runs = (killed / "cfd_runs").string();
  const std::string script =
      std::string(FLAPSTAB_BINARY) + " analyze " + path + " -o " + killed.string() + " > /dev/null 2> " + err_killed +
      " & pid=$!; for i in $(seq 3000); do n=$(ls " + runs + "/run_*.json 2>/dev/null | grep -vc partial); "
      "m=$(ls " + runs + "/run_*.partial.json 2>/dev/null | wc -l); [ $n -ge 2 ] && [ $m -ge 1 ] && break; "
      "sleep 0.02; done; kill -KILL $pid; wait $pid; (ls " + runs + "/run_*.json | grep -vc partial; ls " + runs +
      "/run_*.partial.json 2>/dev/null | wc -l) > " + count;
  ASSERT_EQ(std::system(("bash -c '" + script + "'").c_str()), 0);
  int finished = 0, partial = 0;
  std::ifstream(count) >> finished >> partial;
  {
    std::stringstream hs;
    hs << std::ifstream(err_killed).rdbuf();
    EXPECT_NE(hs.str().find("hover resumed after its wingbeat"), std::string::npos) << hs.str();
  }
  ASSERT_GE(finished, 2);
  ASSERT_LT(finished, 6) << "the analysis finished before it was killed";
  EXPECT_FALSE(fs::exists(killed / "results.json"));
  const std::string err_resumed = write_temp("cfd_resume_resumed.txt", "");
  ASSERT_EQ(WEXITSTATUS(run(killed, err_resumed)), 0);
  std::ifstream log(err_resumed);
  std::stringstream ss;
  ss << log.rdbuf();
  EXPECT_NE(ss.str().find("hover state reused"), std::string::npos) << ss.str();
  std::size_t reused = 0;
  for (std::size_t at = ss.str().find(") reused from"); at != std::string::npos; at = ss.str().find(") reused from", at + 1))
    ++reused;
  EXPECT_GE(reused, std::size_t(finished));
  if (partial > 0) {
    EXPECT_NE(ss.str().find("resumed after its wingbeat"), std::string::npos) << ss.str();
  }
  EXPECT_TRUE(fs::directory_iterator(killed / "cfd_runs") != fs::directory_iterator{});
  for (const auto& f : fs::directory_iterator(killed / "cfd_runs"))
    EXPECT_EQ(f.path().string().find(".partial."), std::string::npos) << "left behind: " << f.path();
  auto results = [](const fs::path& dir) { return nlohmann::json::parse(std::ifstream(dir / "results.json")); };
  const nlohmann::json a = results(whole), b = results(killed);
  ASSERT_TRUE(a.contains("derivatives"));
  EXPECT_EQ(a["derivatives"]["nondimensional"], b["derivatives"]["nondimensional"]);
  EXPECT_EQ(a["derivatives"]["standard_error_nondimensional"], b["derivatives"]["standard_error_nondimensional"]);
  EXPECT_EQ(a["cfd"]["floquet_longitudinal"], b["cfd"]["floquet_longitudinal"]);
  EXPECT_TRUE(a["derivatives"]["planes"]["longitudinal"].get<bool>());
  EXPECT_FALSE(a["derivatives"]["planes"]["lateral"].get<bool>());
  EXPECT_NE(a["derivatives"]["nondimensional"]["Xu"].get<double>(), 0.0);
}

// A campaign: the same analysis started twice at once into one output directory (with mpiexec -n 2 where there is
// one, as on a cluster) shares the run cache: the hover is made once, the derivative runs are split between the two
// processes, and both write the table of the analysis run alone; so do two groups of two MPI ranks in one job
// (--ranks-per-flow 2, each flow over its group); a copy killed half-way loses nothing.
TEST(CfdCli, CampaignOfTwoProcessesGivesTheSerialTable) {
  const std::string text = small_cfd_analysis();
  const std::string path = write_temp("cfdcli_campaign.toml", text);
  const fs::path alone = fs::path(path).parent_path() / "cfdcli_campaign_alone";
  const fs::path shared = fs::path(path).parent_path() / "cfdcli_campaign_shared";
  fs::remove_all(alone);
  fs::remove_all(shared);
  const fs::path logs = fs::path(path).parent_path() / "cfdcli_campaign_logs";
  fs::remove_all(logs);
  fs::create_directories(logs);
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  auto count = [](const std::string& s, const std::string& what) {
    int n = 0;
    for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
    return n;
  };
  auto made = [](const std::string& s) {
    const std::regex done("cfd model: run [0-9]+ done:");
    return int(std::distance(std::sregex_iterator(s.begin(), s.end(), done), std::sregex_iterator()));
  };
  // A copy killed in the middle of its run (SIGKILL: its claims end with it): the other copy makes that run too
  // (from the killed copy's last whole wingbeat, when one was kept) and the table is still the lone run's. The lone
  // run goes alongside (the test runs with no other test beside it, and the survivor keeps one core busy).
  const fs::path survived = fs::path(path).parent_path() / "cfdcli_campaign_survived";
  fs::remove_all(survived);
  const std::string la = (logs / "survivor.txt").string(), lb = (logs / "killed.txt").string();
  const std::string copy =
      std::string(FLAPSTAB_BINARY) + " analyze " + path + " -o " + survived.string() + " > /dev/null";
  const std::string lone = std::string(FLAPSTAB_BINARY) + " analyze " + path + " -o " + alone.string() +
                           " > /dev/null 2> " + write_temp("cfd_campaign_alone.txt", "");
  const std::string script = lone + " & c=$!; " + copy + " 2> " + la + " & a=$!; " + copy + " 2> " + lb +
                             " & b=$!; for i in $(seq 3000); do grep -q \"wingbeat  2: difference\" " + lb +
                             " 2>/dev/null && break; sleep 0.02; done; kill -KILL $b; wait $b; wait $a; x=$?; wait $c; "
                             "y=$?; exit $((x | y))";
  ASSERT_EQ(WEXITSTATUS(std::system(("bash -c '" + script + "'").c_str())), 0);
  const std::string killed_log = slurp(lb), survivor_log = slurp(la);
  EXPECT_EQ(made(killed_log), 0) << killed_log;  // killed in its first run
  EXPECT_EQ(made(survivor_log), 6) << survivor_log;
  auto results = [](const fs::path& dir) { return nlohmann::json::parse(std::ifstream(dir / "results.json")); };
  const nlohmann::json x = results(alone), z = results(survived);
  ASSERT_TRUE(x.contains("derivatives"));
  EXPECT_EQ(x["derivatives"]["nondimensional"], z["derivatives"]["nondimensional"]);
  EXPECT_EQ(x["cfd"]["floquet_longitudinal"], z["cfd"]["floquet_longitudinal"]);

  const std::string one = std::string(FLAPSTAB_BINARY) + " analyze " + path + " -o " + shared.string() + " > /dev/null";
#ifdef FLAPSTAB_MPIEXEC
  // Each rank writes its own log (OMPI_COMM_WORLD_RANK under Open MPI, PMI_RANK under MPICH).
  const char* flags = std::getenv("FLAPSTAB_TEST_MPI_FLAGS");
  const std::string launch = std::string(FLAPSTAB_MPIEXEC) +
                             (flags ? flags : " --allow-run-as-root --oversubscribe --bind-to none") +
                             " -n 2 bash -c '" + one + " 2> " + logs.string() +
                             "/rank${OMPI_COMM_WORLD_RANK:-${PMI_RANK:-x}}.txt'";
#else
  const std::string launch = "bash -c '" + one + " 2> " + logs.string() + "/rank0.txt & a=$!; " + one + " 2> " +
                             logs.string() + "/rank1.txt & b=$!; wait $a && wait $b'";
#endif
  ASSERT_EQ(WEXITSTATUS(std::system(launch.c_str())), 0) << launch;
  const std::string a = slurp(logs / "rank0.txt"), b = slurp(logs / "rank1.txt");
  ASSERT_FALSE(a.empty());
  ASSERT_FALSE(b.empty());
  // The hover once; the six derivative runs once each, by both processes.
  EXPECT_EQ(count(a, "hover from rest") + count(b, "hover from rest"), 1) << a << b;
  const int made_a = made(a), made_b = made(b);
  EXPECT_EQ(made_a + made_b, 6) << a << b;
  EXPECT_GE(made_a, 1) << a;
  EXPECT_GE(made_b, 1) << b;
  const nlohmann::json y = results(shared);
  EXPECT_EQ(x["derivatives"]["nondimensional"], y["derivatives"]["nondimensional"]);
  EXPECT_EQ(x["derivatives"]["standard_error_nondimensional"], y["derivatives"]["standard_error_nondimensional"]);
  EXPECT_EQ(x["cfd"]["floquet_longitudinal"], y["cfd"]["floquet_longitudinal"]);
  EXPECT_EQ(x["cfd"]["continued_hover"], y["cfd"]["continued_hover"]);

#if defined(FLAPSTAB_MPIEXEC) && defined(FLAPSTAB_HAVE_MPI)
  // The same campaign as two groups of two ranks in one job (--ranks-per-flow 2): each flow over its group's two
  // ranks (z slabs), the groups sharing the runs. Each group's rank 0 speaks for it; its rank 1 says nothing. The
  // table is the lone run's to 1e-6 of its largest entry: a flow over ranks is the one-process flow to round-off in
  // each step (tests/mpi), but at the default pressure tolerance (1e-3) round-off decides one more pressure
  // iteration here and there (measured: 1e-10 of the loads; the tiny cross-coupling entries, zero by symmetry, differ
  // by up to 3e-9 of 6.4); a group that skipped a run or read another's state would differ by O(1).
  {
    const fs::path grouped = fs::path(path).parent_path() / "cfdcli_campaign_groups";
    fs::remove_all(grouped);
    const fs::path glogs = fs::path(path).parent_path() / "cfdcli_campaign_group_logs";
    fs::remove_all(glogs);
    fs::create_directories(glogs);
    const std::string glaunch =
        "OMP_NUM_THREADS=1 " + mpiexec(4) + "bash -c '" + FLAPSTAB_BINARY + " analyze " + path + " -o " +
        grouped.string() + " --ranks-per-flow 2 > /dev/null 2> " +
        glogs.string() + "/rank${OMPI_COMM_WORLD_RANK:-${PMI_RANK:-x}}.txt'";
    ASSERT_EQ(WEXITSTATUS(std::system(glaunch.c_str())), 0) << glaunch;
    const std::string g0 = slurp(glogs / "rank0.txt"), g2 = slurp(glogs / "rank2.txt");
    EXPECT_EQ(slurp(glogs / "rank1.txt"), "");
    EXPECT_EQ(slurp(glogs / "rank3.txt"), "");
    EXPECT_EQ(count(g0, "hover from rest") + count(g2, "hover from rest"), 1) << g0 << g2;
    EXPECT_EQ(made(g0) + made(g2), 6) << g0 << g2;
    EXPECT_GE(made(g0), 1) << g0;
    EXPECT_GE(made(g2), 1) << g2;
    const nlohmann::json g = results(grouped);
    ASSERT_TRUE(g.contains("derivatives"));
    const auto& a = x["derivatives"]["nondimensional"];
    const auto& b = g["derivatives"]["nondimensional"];
    double largest = 0;
    for (const auto& [k, v] : a.items())
      if (v.is_number()) largest = std::max(largest, std::abs(v.get<double>()));
    ASSERT_GT(largest, 0.0);
    for (const auto& [k, v] : a.items()) {
      if (!v.is_number()) {
        EXPECT_EQ(v, b[k]) << k;
        continue;
      }
      ASSERT_TRUE(b[k].is_number()) << k;
      EXPECT_NEAR(b[k].get<double>(), v.get<double>(), 1e-6 * largest) << k;
    }
  }
#endif
}

#if defined(FLAPSTAB_MPIEXEC) && defined(FLAPSTAB_HAVE_MPI)
// --ranks-per-flow (the CFD model's flows over groups of ranks) where it cannot apply: bad input with one message
// (the job's rank 0, or each group's rank 0) naming the option or the case key, status 2, nothing written.
TEST(CfdCli, RanksPerFlowWhereItCannotApplyIsBadInput) {
  const std::string cfd_case = write_temp("cfdcli_groups_bad.toml", small_cfd_analysis());
  const std::string fpm_case = write_temp("cfdcli_groups_fpm.toml", small_cfd_analysis() + "\n[aero.cfd.fpm]\n");
  const std::string qs_case = write_temp("cfdcli_groups_qs.toml", testing::valid_cfd_case_text());
  const fs::path dir = fs::path(cfd_case).parent_path() / "cfdcli_groups_bad";
  struct Case {
    const char* label;
    std::string prefix, args, says;
    int messages;
  };
  const std::string mpi = "OMP_NUM_THREADS=1 " + mpiexec(4);
  const std::string out = " -o " + dir.string();
  for (const Case& c : std::vector<Case>{
           {"groups that are not whole", mpi, "derivatives " + cfd_case + out + " --ranks-per-flow 3",
            "3 ranks per flow, but mpiexec started 4 processes", 1},
           {"no mpiexec", "", "analyze " + cfd_case + out + " --ranks-per-flow 2", "need processes started by mpiexec",
            1},
           {"more ranks than the grid takes", "OMP_NUM_THREADS=1 " + mpiexec(8),
            "trim-hover " + cfd_case + out + " --ranks-per-flow 8",
            "'--ranks-per-flow': 8 ranks cannot share this grid",
            1},
           {"the quasi-steady model", mpi, "derivatives " + qs_case + out + " --ranks-per-flow 2", "'aero.model'", 2},
           {"force partitioning", mpi, "stability " + fpm_case + out + " --ranks-per-flow 2",
            "'aero.cfd.fpm.enabled'", 2}}) {
    fs::remove_all(dir);
    const CfdRunOutput r = run_flapstab(c.prefix, c.args);
    EXPECT_EQ(r.status, 2) << c.label << "\n" << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << c.label << "\n" << r.err;
    EXPECT_EQ(occurrences(r.err, "flapstab: error"), c.messages) << c.label << "\n" << r.err;  // a rank 0 per group
    EXPECT_FALSE(fs::exists(dir)) << c.label;
  }
}
#endif

TEST(CfdCli, HelpDescribesTheOptions) {
  const CfdRunOutput r = flapstab_cfd("--help");
  EXPECT_EQ(r.status, 0);
  for (const char* k : {"--restart", "--cycles", "--steps", "--dry-run", "-o,--output", "forces.csv", "SIGTERM"})
    EXPECT_NE(r.out.find(k), std::string::npos) << k << "\n" << r.out;
}


// `flapstab derivatives` on a case text into a fresh directory: exit status, stdout, stderr and derivatives.json
// (null when none was written).
struct DerivativesRun {
  int rc = -1;
  std::string out, err;
  std::string dir;  // the output directory (its cfd_runs: the run cache)
  nlohmann::json json;
};
// `fresh`: from an empty output directory (otherwise its run cache is kept)
DerivativesRun run_derivatives(const std::string& text, const std::string& name, bool fresh = true) {
  const std::string path = write_temp("cfdcli_" + name + ".toml", text);
  const fs::path dir = fs::path(path).parent_path() / ("cfdcli_" + name + "_dir");
  if (fresh) fs::remove_all(dir);
  const std::string outfile = write_temp("cfd_" + name + "_stdout.txt", "");
  const std::string errfile = write_temp("cfd_" + name + "_stderr.txt", "");
  DerivativesRun r;
  r.dir = dir.string();
  r.rc = WEXITSTATUS(std::system((std::string(FLAPSTAB_BINARY) + " derivatives " + path + " -o " + dir.string() +
                                  " > " + outfile + " 2> " + errfile).c_str()));
  auto slurp = [](const std::string& f) {
    std::ifstream in(f);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  r.out = slurp(outfile);
  r.err = slurp(errfile);
  if (fs::exists(dir / "derivatives.json")) r.json = nlohmann::json::parse(slurp((dir / "derivatives.json").string()));
  return r;
}

// With [aero.cfd.fpm] a CFD derivative table comes with its velocity columns split by mechanism (the force partition's
// window-mean differences of the same runs): in derivatives.json and on the terminal, one row per partitioned load
// and velocity column, the rate column left out (its grid turns). The table's own value is carried beside; the
// kinematic part of a velocity derivative vanishes (the parts move in the body's frame as in the hover).
TEST(CfdCli, DerivativesWithForcePartitioningAreSplitByMechanism) {
  const std::string text = small_cfd_analysis() +
                           "\n[aero.cfd.fpm]\nsamples_per_cycle = 20\ncomponents = [\"Fx\", \"Fz\", \"My\"]\n";
  const DerivativesRun r = run_derivatives(text, "split");
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string& out = r.out;
  const nlohmann::json& j = r.json;
  const auto& split = j.at("cfd").at("derivatives_by_mechanism");
  std::vector<std::string> names;
  for (const auto& m : split) {
    const std::string name = m.at("derivative").get<std::string>();
    names.push_back(name);
    const double pressure = m.at("pressure").get<double>();
    const double kinematic = m.at("added_mass").get<double>() + m.at("centripetal").get<double>();
    EXPECT_LE(std::abs(kinematic), 1e-3 * std::abs(pressure)) << name;
    EXPECT_NEAR(m.at("sum").get<double>(), kinematic + m.at("vortex").get<double>() + m.at("viscous").get<double>() +
                                               m.at("outer").get<double>(), 1e-12) << name;
    EXPECT_EQ(m.at("total").get<double>(), j.at("derivatives").at("nondimensional").at(name).get<double>()) << name;
  }
  EXPECT_EQ(names, (std::vector<std::string>{"Xu", "Zu", "Mu", "Xw", "Zw", "Mw"}));
  const std::size_t at = out.find("Velocity derivatives split by mechanism");
  ASSERT_NE(at, std::string::npos) << out;
  EXPECT_NE(out.find("| Mu |", at), std::string::npos) << out;
  EXPECT_EQ(out.find("| Mq |", at), std::string::npos) << "the rate column is not split: " << out;
  EXPECT_NE(out.find("on the forced faces", at), std::string::npos) << out;
  for (const auto& m : split) EXPECT_TRUE(std::isfinite(m.at("pressure_forced").get<double>()));
  // Partitions cached under another definition (an earlier flapstab's, without "definition") are not reused: the
  // same command on the same cache, its runs reused, then leaves the split out instead of mixing definitions.
  int stripped = 0;
  for (const auto& e : fs::directory_iterator(fs::path(r.dir) / "cfd_runs")) {
    if (e.path().extension() != ".json") continue;
    std::ifstream in(e.path());
    nlohmann::json c = nlohmann::json::parse(in, nullptr, false);
    if (c.is_discarded() || !c.contains("partition")) continue;
    auto strip = [&](nlohmann::json& p) {
      if (p.is_object() && p.contains("definition")) p.erase("definition"), ++stripped;
    };
    if (c["partition"].is_array())
      for (auto& p : c["partition"]) strip(p);
    else
      strip(c["partition"]);
    std::ofstream(e.path()) << c.dump(1) << "\n";
  }
  EXPECT_GT(stripped, 0);
  const DerivativesRun again = run_derivatives(text, "split", false);
  ASSERT_EQ(again.rc, 0) << again.err;
  EXPECT_EQ(again.json.at("derivatives").at("nondimensional"), j.at("derivatives").at("nondimensional"));
  EXPECT_TRUE(again.json.at("cfd").at("derivatives_by_mechanism").empty()) << again.out;
}

// [derivatives.pitch_oscillation] in a CFD study: the oscillation keeps each step's difference from the continued
// hover, fits it phase by phase, and the study writes the Floquet analysis of the CFD A(t) with those phase-resolved
// q and theta columns beside the one with the steady-rate column, with the cycle means of the per-phase fits.
TEST(CfdCli, PitchOscillationGivesAFloquetAnalysisWithItsColumns) {
  const std::string text = small_cfd_analysis() +
                           "\n[derivatives.pitch_oscillation]\namplitude_deg = 2\nperiod_wingbeats = 4\n"
                           "transient_wingbeats = 2\nperiods = 1\n";
  const DerivativesRun r = run_derivatives(text, "osc");
  ASSERT_EQ(r.rc, 0) << r.err;
  const std::string& out = r.out;
  const nlohmann::json& j = r.json;
  const auto& po = j.at("cfd").at("pitch_oscillation");
  EXPECT_EQ(po.at("floquet_note").get<std::string>(), "");
  ASSERT_TRUE(po.at("floquet_longitudinal").is_object()) << po.dump(1);
  EXPECT_EQ(po.at("floquet_longitudinal").at("multipliers").size(), 4u);
  EXPECT_EQ(po.at("floquet_longitudinal").at("states"), j.at("cfd").at("floquet_longitudinal").at("states"));
  const auto& mq = po.at("derivatives_nd").at("Mq");
  ASSERT_TRUE(mq.contains("phase_resolved_mean")) << mq.dump();
  EXPECT_TRUE(std::isfinite(mq.at("phase_resolved_mean").get<double>()));
  // The oscillatory mode: the Floquet pair with these columns and the LTI mode with the wingbeat fits agree on its
  // stability (measured on this grid: exponent +0.185 +- 0.271i per wingbeat against the LTI's +0.177 +- 0.293i).
  double growth_floquet = 0, growth_lti = 0;
  bool pair = false, mode = false;
  for (const auto& e : po.at("floquet_longitudinal").at("exponents_per_wingbeat"))
    if (std::abs(e.at(1).get<double>()) > 0 && !pair) {
      growth_floquet = e.at(0).get<double>();
      pair = true;
    }
  for (const auto& m : po.at("modes").at("modes"))
    if (m.at("conjugate_pair").get<bool>() && !mode) {
      growth_lti = m.at("eigenvalue_per_wingbeat").at(0).get<double>();
      mode = true;
    }
  ASSERT_TRUE(pair && mode) << po.dump(1);
  EXPECT_EQ(growth_floquet > 0, growth_lti > 0) << growth_floquet << " " << growth_lti;
  EXPECT_NE(out.find("with the oscillation's phase-resolved q and theta columns"), std::string::npos) << out;
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
