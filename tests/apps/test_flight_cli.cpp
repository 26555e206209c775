// flapstab fly and flapstab control-map end to end: the files, their headers and keys, and bad input (exit status
// 2, the file and key named, nothing written).
#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include "common/case_text.hpp"

namespace flapstab {
namespace {

namespace fs = std::filesystem;

struct CliResult {
  int status;
  std::string out, err;
};

// A file's whole text ("" when it cannot be read).
std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

CliResult flapstab(const std::string& args) {
  const std::string o = testing::write_temp("fly_stdout.txt", ""), e = testing::write_temp("fly_stderr.txt", "");
  const int rc = std::system((std::string(FLAPSTAB_BINARY) + " " + args + " > " + o + " 2> " + e).c_str());
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(o), slurp(e)};
}

std::string hawkmoth_text() {
  std::ifstream in(std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("flapstab_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d.string();
}

TEST(FlyCli, HawkmothClosedLoopWritesTrajectoryAndRunJson) {
  const std::string dir = fresh_dir("fly");
  const CliResult r = flapstab("fly " + std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml -o " + dir +
                         " --wingbeats 6 -q");
  ASSERT_EQ(r.status, 0) << r.err;
  std::ifstream csv(dir + "/trajectory.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  EXPECT_EQ(header.rfind("t_s,wingbeat,x_m,y_m,z_m,u_m_s", 0), 0u) << header;  // one header row, units in names
  EXPECT_NE(header.find(",dtheta_rad,"), std::string::npos);
  EXPECT_NE(header.find(",command_stroke_plane_deg"), std::string::npos);
  int rows = 1;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, 6 * 40 + 1);
  std::ifstream js(dir + "/run.json");
  const auto j = nlohmann::json::parse(js);
  EXPECT_EQ(j.at("command"), "fly");
  EXPECT_EQ(j.at("flight").at("dof"), "longitudinal");
  EXPECT_TRUE(j.at("result").at("completed").get<bool>());
  EXPECT_EQ(j.at("controller").at("terms").size(), 2u);
  EXPECT_EQ(j.at("result").at("deviation_per_wingbeat_nd").size(), 6u);
}

// The general state-feedback law written out as the pitch controller's two terms gives the same trajectory, and a
// perturbation along the lateral Floquet mode (6DoF) is taken from the cyclic trim's monodromy.
TEST(FlyCli, StateFeedbackEqualsThePitchControllerAndModePerturbation) {
  const std::string h = hawkmoth_text();
  const std::string a = fresh_dir("fly_pitch"), b = fresh_dir("fly_state");
  const std::string pitch = testing::write_temp("fly_pitch.toml", h);
  // 0.5 deg/deg = 0.5 * 180/pi deg per rad; 0.05 s = 0.05 * 180/pi deg per rad/s; limits -15 -/+ 20 deg (the
  // stroke plane is not a trim parameter of the case, so it stays at -15 deg).
  std::string sf = h;
  sf.replace(sf.find("type = \"pitch\""), std::string("type = \"pitch\"").size(), "type = \"state-feedback\"");
  sf += "\n[[control.feedback]]\nstate = \"theta\"\nactuator = \"stroke_plane_deg\"\ngain = 28.64788975654116\n"
        "latency_s = 0.041\n"
        "[[control.feedback]]\nstate = \"q\"\nactuator = \"stroke_plane_deg\"\ngain = 2.864788975654116\n"
        "latency_s = 0.041\n"
        "[[control.actuator]]\nname = \"stroke_plane_deg\"\nlower = -35.0\nupper = 5.0\n";
  const std::string state = testing::write_temp("fly_state.toml", sf);
  ASSERT_EQ(flapstab("fly " + pitch + " -o " + a + " --wingbeats 4 -q").status, 0);
  const CliResult r = flapstab("fly " + state + " -o " + b + " --wingbeats 4 -q");
  ASSERT_EQ(r.status, 0) << r.err;
  std::ifstream fa(a + "/trajectory.csv"), fb(b + "/trajectory.csv");
  std::string la, lb;
  int rows = 0;
  while (std::getline(fa, la) && std::getline(fb, lb)) {
    if (rows++ == 0) continue;
    std::stringstream sa(la), sb(lb);
    std::string ca, cb;
    int col = 0;
    while (std::getline(sa, ca, ',') && std::getline(sb, cb, ',')) {
      const double x = std::stod(ca), y = std::stod(cb);
      EXPECT_NEAR(x, y, 1e-9 * (1 + std::abs(x))) << "row " << rows << " column " << col;
      ++col;
    }
  }
  EXPECT_EQ(rows, 4 * 40 + 2);
  std::string m = h;
  m.replace(m.find("theta_deg = 0.5"), std::string("theta_deg = 0.5").size(), "mode = \"lateral\"\nmode_amplitude = 1e-4");
  m.replace(m.find("dof = \"longitudinal\""), std::string("dof = \"longitudinal\"").size(), "dof = \"6dof\"");
  const std::string c = fresh_dir("fly_mode");
  const CliResult rm = flapstab("fly " + testing::write_temp("fly_mode.toml", m) + " -o " + c + " --wingbeats 2 -q");
  ASSERT_EQ(rm.status, 0) << rm.err;
  std::ifstream js(c + "/run.json");
  const auto j = nlohmann::json::parse(js);
  const auto mu = j.at("flight").at("mode_multiplier");
  EXPECT_GT(std::hypot(mu[0].get<double>(), mu[1].get<double>()), 1.0);  // the lateral divergence
  EXPECT_NE(j.at("flight").at("initial_state").at("phi_rad").get<double>(), 0.0);
  // The growth is a fit over the second half of the flight and needs two wingbeats there: the 4-wingbeat flight has
  // it (wingbeats 2-3), the 2-wingbeat one says why it has none (null in run.json, a note, and the terminal line).
  std::ifstream ja(a + "/run.json");
  const auto four = nlohmann::json::parse(ja).at("result");
  EXPECT_TRUE(four.at("growth_per_wingbeat").is_number());
  EXPECT_EQ(four.at("growth_fit_wingbeats"), nlohmann::json({2, 3}));
  EXPECT_FALSE(four.contains("growth_note"));
  const auto two = j.at("result");
  EXPECT_TRUE(two.at("growth_per_wingbeat").is_null());
  EXPECT_TRUE(two.at("mean_growth_per_wingbeat").is_null());
  EXPECT_NE(two.at("growth_note").get<std::string>().find("at least two"), std::string::npos);
  const CliResult loud = flapstab("fly " + testing::write_temp("fly_mode.toml", m) + " -o " + fresh_dir("fly_mode2") +
                                  " --wingbeats 2");
  ASSERT_EQ(loud.status, 0) << loud.err;
  EXPECT_NE(loud.out.find("growth per wingbeat not fitted"), std::string::npos) << loud.out;
  EXPECT_EQ(loud.out.find("+nan"), std::string::npos) << loud.out;
}

// Bad input is refused before any work: exit status 2, the key named, no output directory.
void expect_refused(const std::string& text, const std::string& command, const std::string& key) {
  const std::string path = testing::write_temp("bad_flight.toml", text);
  const std::string dir = fresh_dir("bad");
  const CliResult r = flapstab(command + " " + path + " -o " + dir + " -q");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'" + key + "'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir)) << command << " wrote " << dir;
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto p = text.find(from);
  if (p == std::string::npos) throw std::runtime_error("test: '" + from + "' not in the case text");
  return text.replace(p, from.size(), to);
}

TEST(FlyCli, BadInputNamesFileAndKey) {
  const std::string h = hawkmoth_text();
  expect_refused(replaced(h, "pitch_latency_s = 0.041", "pitch_latency_s = -0.01"), "fly", "control.pitch.pitch_latency_s");
  expect_refused(replaced(h, "pitch_gain = 0.5 ", "pitch_gain = nan "), "fly", "control.pitch.pitch_gain");
  expect_refused(replaced(h, "dof = \"longitudinal\"", "dof = \"5dof\""), "fly", "flight.dof");
  expect_refused(replaced(h, "theta_deg = 0.5", "v_m_s = 0.1"), "fly", "flight.perturbation");
  expect_refused(replaced(h, "theta_deg = 0.5", "alpha_deg = 0.5"), "fly", "flight.perturbation.alpha_deg");
  expect_refused(replaced(h, "actuator = \"stroke_plane_deg\"", "actuator = \"wing_twist_deg\""), "fly",
                 "control.pitch.actuator");
  expect_refused(replaced(h, "type = \"pitch\"", "type = \"state-feedback\"") +
                     "\n[[control.feedback]]\nstate = \"alpha\"\nactuator = \"stroke_plane_deg\"\ngain = 1.0\n",
                 "fly", "control.feedback[0].state");
  expect_refused(replaced(h, "type = \"pitch\"", "type = \"state-feedback\"") +
                     "\n[[control.feedback]]\nstate = \"theta\"\nactuator = \"stroke_plane_deg\"\ngain = 1.0\n",
                 "fly", "control.feedback[0].actuator");  // no [[control.actuator]] with its limits
  expect_refused(replaced(h, "start = \"periodic-orbit\"", "start = \"periodic-orbit\"\ncfd_residual = \"drop\""), "fly",
                 "flight.cfd_residual");
  expect_refused(replaced(h, "type = \"pitch\"", "type = \"none\""), "control-map", "control.type");
  expect_refused(replaced(h, "gain_max = 2.0", "gain_max = -1.0"), "control-map", "control.map.gain_max");
  // A number option that is not a finite number (CLI11's range check alone let "nan" through: the case's wingbeats
  // were flown instead).
  const std::string dir = fresh_dir("bad_wingbeats");
  const CliResult r = flapstab("fly " + testing::write_temp("fly_ok.toml", h) + " -o " + dir + " --wingbeats nan -q");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--wingbeats: Value nan is not a finite number"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir));
}

// A small map (8 x 8, one check point each side): the JSON's keys, the boundary and the agreement of the
// averaged, periodic and simulated models at the check points.
TEST(ControlMapCli, SmallHawkmothMap) {
  std::string h = hawkmoth_text();
  h = replaced(h, "gains = 50", "gains = 8\ncheck_points = 1\ncheck_wingbeats = 12\nperiodic_gains = 3\nperiodic_latencies = 3");
  h = replaced(h, "latencies = 50", "latencies = 8");
  const std::string path = testing::write_temp("map_case.toml", h);
  const std::string dir = fresh_dir("map");
  const CliResult r = flapstab("control-map " + path + " -o " + dir + " -q");
  ASSERT_EQ(r.status, 0) << r.err;
  std::ifstream js(dir + "/control_map.json");
  const auto j = nlohmann::json::parse(js);
  EXPECT_EQ(j.at("map").at("gains").size(), 8u);
  EXPECT_EQ(j.at("map").at("spectral_abscissa_per_s").size(), 8u);
  EXPECT_EQ(j.at("boundary").size(), 8u);
  EXPECT_GT(j.at("open_loop").at("lti_growth_per_wingbeat").get<double>(), 0);  // the hover is unstable alone
  ASSERT_EQ(j.at("check_points").size(), 2u);
  for (const auto& p : j.at("check_points")) EXPECT_TRUE(p.at("all_three_agree").get<bool>()) << p.dump();
  // The periodic loop's 3 x 3 map (gains -0.5, 0.75, 2; latencies 0, 1.5, 3 wingbeats) lies away from the boundary:
  // the averaged and periodic models agree at every point.
  ASSERT_TRUE(j.contains("periodic_map"));
  EXPECT_EQ(j.at("periodic_map").at("points").get<int>(), 9);
  EXPECT_EQ(j.at("periodic_map").at("points_where_averaged_and_periodic_agree").get<int>(), 9);
  EXPECT_TRUE(fs::exists(dir + "/control_map_periodic.svg"));
  const double best = j.at("best_gain").at("critical_latency_averaged").at("wingbeats").get<double>();
  EXPECT_GT(best, 0.5);
  std::ifstream csv(dir + "/control_map.csv");
  std::string header;
  std::getline(csv, header);
  EXPECT_EQ(header, "gain,latency_s,latency_wingbeats,spectral_abscissa_per_s,growth_per_wingbeat,stable");
}

// Check flights too short for a growth (check_wingbeats = 1: the fit needs two wingbeats in the second half) are not
// compared: their growth reads "not fitted" and their agreement null in the JSON, and the terminal says how many were
// left out instead of counting them as disagreements (it printed "+nan/wb  (models disagree)" and "1 of 2 agree").
TEST(ControlMapCli, CheckFlightsTooShortForAGrowthAreNotCompared) {
  std::string h = hawkmoth_text();
  h = replaced(h, "gains = 50", "gains = 8\ncheck_points = 1\ncheck_wingbeats = 1\nperiodic_gains = 0\n"
                                      "periodic_latencies = 0");
  h = replaced(h, "latencies = 50", "latencies = 8");
  const std::string dir = fresh_dir("map_short");
  const CliResult r = flapstab("control-map " + testing::write_temp("map_short.toml", h) + " -o " + dir);
  ASSERT_EQ(r.status, 0) << r.err;
  std::ifstream js(dir + "/control_map.json");
  const auto j = nlohmann::json::parse(js);
  ASSERT_EQ(j.at("check_points").size(), 2u);
  for (const auto& p : j.at("check_points")) {
    EXPECT_EQ(p.at("simulated_growth_per_wingbeat"), "not fitted") << p.dump();
    EXPECT_TRUE(p.at("all_three_agree").is_null()) << p.dump();
  }
  EXPECT_NE(r.out.find("2 check points not compared"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("models disagree"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("+nan"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace flapstab

namespace flapstab {
namespace {

// The test moth under the Navier-Stokes model on a tiny grid (4 cells per chord, 120 steps per wingbeat, Re 20).
std::string tiny_cfd_case_text() {
  std::string text = testing::valid_cfd_case_text();
  text = replaced(text, "model = \"quasi-steady\"", "model = \"cfd\"");
  return replaced(text, "[trim]\n",
                  "[aero.cfd]\ncells_per_chord = 4\nfine_margin_R = 0.4\nupstream_R = 0\ndownstream_R = 0\n"
                  "lateral_R = 0\nabove_R = 0\nbelow_R = 0.5\nsteps_per_cycle = 120\nbody_divisions = 6\n"
                  "wing_span_stations = 12\nwing_chord_divisions = 4\nthreads = 1\nreynolds = 20\ncycles = 2\n"
                  "max_cycles = 2\ntrim_iterations = 0\n\n[trim]\n");
}

// fly with model = "cfd" end to end on a tiny grid (the test moth at 4 cells per mean chord, Re = 20, 120 steps per
// wingbeat; its quasi-steady trim, not refined on the CFD loads), closed loop: the hover, the unperturbed reference
// flight (open loop) and the perturbed one under the pitch controller; the files and their keys; and a run extended
// from its checkpoint (1 wingbeat, then --wingbeats 2) equal to the straight run bit for bit.
TEST(FlyCli, CfdClosedLoopWritesItsFilesAndResumesExactly) {
  std::string text = tiny_cfd_case_text();
  text += "\n[flight]\ndof = \"longitudinal\"\nwingbeats = 2\nsamples_per_wingbeat = 20\n[flight.perturbation]\n"
          "q_deg_s = 50.0\n";
  // Closed loop: the pitch controller on the stroke plane, its latency not a whole number of steps (T / 120 =
  // 0.3205 ms at 26 Hz; 5 ms = 15.6 steps), so a resumed run must rebuild the interpolated sensed history.
  const std::string open_loop = text;
  text += "\n[control]\ntype = \"pitch\"\n[control.pitch]\nactuator = \"stroke_plane_deg\"\npitch_gain = 2.0\n"
          "rate_gain_s = 0.05\npitch_latency_s = 0.005\nrate_latency_s = 0.005\nlimit_deg = 20\n";
  const std::string path = testing::write_temp("fly_cfd.toml", text);
  const std::string a = fresh_dir("fly_cfd_a"), b = fresh_dir("fly_cfd_b");
  const CliResult ra = flapstab("fly " + path + " -o " + a);
  ASSERT_EQ(ra.status, 0) << ra.out << ra.err;
  EXPECT_NE(ra.out.find("the unperturbed flight first (the reference)"), std::string::npos) << ra.out;
  EXPECT_NE(ra.out.find("residual"), std::string::npos) << ra.out;
  for (const char* f : {"trajectory.csv", "steps.csv", "run.json", "flight_checkpoint.h5", "reference_checkpoint.h5",
                        "fields", "surfaces"})
    EXPECT_TRUE(fs::exists(fs::path(a) / f)) << f;
  std::ifstream in(fs::path(a) / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["flight"]["cfd_residual"], "cancel");
  EXPECT_TRUE(j["flight"]["hover_residual"].contains("force_N"));
  EXPECT_EQ(j["result"]["steps"], 240);
  EXPECT_TRUE(j["result"]["completed"].get<bool>());
  EXPECT_EQ(j["cfd"]["steps_per_wingbeat"], 120);
  EXPECT_NE(std::string(j["result"]["reference"]).find("unperturbed"), std::string::npos);
  EXPECT_NE(ra.out.find("controller: pitch feedback on stroke_plane_deg"), std::string::npos) << ra.out;
  EXPECT_NE(std::string(j["flight"]["controller"]["senses"]).find("unperturbed flight"), std::string::npos);
  {  // the command column: zero until the first delayed sample of the perturbation arrives, then moving
    std::ifstream st(fs::path(a) / "steps.csv");
    std::string header, line;
    std::getline(st, header);
    EXPECT_NE(header.find(",command_stroke_plane_deg"), std::string::npos) << header;
    double first = 0, largest = 0;
    for (int row = 0; std::getline(st, line); ++row) {
      const double u = std::stod(line.substr(line.rfind(',') + 1));
      if (row <= 15) first = std::max(first, std::abs(u));
      largest = std::max(largest, std::abs(u));
    }
    EXPECT_EQ(first, 0.0);  // steps 0-15 sense before the start (15.6 steps of latency)
    std::ifstream tr(fs::path(a) / "trajectory.csv");
    std::getline(tr, header);
    EXPECT_NE(header.find(",command_stroke_plane_deg,cfl"), std::string::npos) << header;
    std::getline(tr, line);  // the start: no step yet, CFL 0
    std::getline(tr, line);
    const double cfl = std::stod(line.substr(line.rfind(',') + 1));
    EXPECT_GT(cfl, 0.0);  // the solver's CFL at the sample's step
    EXPECT_GT(largest, 0.1);  // deg: 50 deg/s of pitch rate x 0.05 s = 2.5 deg at the start
  }
  const CliResult rb1 = flapstab("fly " + path + " -o " + b + " --wingbeats 1");
  ASSERT_EQ(rb1.status, 0) << rb1.err;
  const CliResult rb2 = flapstab("fly " + path + " -o " + b + " --wingbeats 2");
  ASSERT_EQ(rb2.status, 0) << rb2.err;
  EXPECT_NE(rb2.out.find("resumed from"), std::string::npos) << rb2.out;
  EXPECT_NE(rb2.out.find("hover state reused"), std::string::npos) << rb2.out;
  const std::string ta = slurp(fs::path(a) / "trajectory.csv"), tb = slurp(fs::path(b) / "trajectory.csv");
  EXPECT_GT(ta.size(), 1000u);
  EXPECT_EQ(ta, tb);
  EXPECT_EQ(slurp(fs::path(a) / "steps.csv"), slurp(fs::path(b) / "steps.csv"));
  // Along the quasi-steady model's longitudinal Floquet mode (6 steps): the hover and the reference flight reused,
  // the perturbation the mode's (u, w, q and theta moved, the lateral states not).
  std::string m = replaced(text, "q_deg_s = 50.0", "mode = \"longitudinal\"\nmode_amplitude = 1e-3");
  const CliResult rm = flapstab("fly " + testing::write_temp("fly_cfd_mode.toml", m) + " -o " + a + " --wingbeats 0.05");
  ASSERT_EQ(rm.status, 0) << rm.out << rm.err;
  EXPECT_NE(rm.out.find("longitudinal Floquet mode"), std::string::npos) << rm.out;
  EXPECT_NE(rm.out.find("reference: resumed"), std::string::npos) << rm.out;
  std::ifstream jm(fs::path(a) / "run.json");
  const nlohmann::json km = nlohmann::json::parse(jm);
  const auto& x = km["flight"]["initial_state"];
  EXPECT_GT(std::abs(x["u_m/s"].get<double>()) + std::abs(x["q_rad/s"].get<double>()), 0.0) << x.dump();
  EXPECT_EQ(x["v_m/s"].get<double>(), 0.0);
  EXPECT_GT(std::hypot(km["flight"]["mode_multiplier"][0].get<double>(), km["flight"]["mode_multiplier"][1].get<double>()), 0.0);
  EXPECT_EQ(km["result"]["steps"], 6);
  // The fine box holds the wings at the controller's limits (stroke plane +-20 deg), so the open loop plans a smaller
  // grid and cannot reuse this directory's hover. A controller whose range lies inside the trim bounds (stroke mean
  // +-5 deg, the trim's +-40 deg) plans the same grid: an open-loop flight then reuses the hover and the reference
  // flight written under that controller (with its command column).
  const std::string c_dir = fresh_dir("fly_cfd_c");
  const std::string inside = open_loop + "\n[control]\ntype = \"pitch\"\n[control.pitch]\nactuator = \"stroke_mean_deg\"\n"
                                         "pitch_gain = 1.0\nlimit_deg = 5\n";
  const CliResult rc = flapstab("fly " + testing::write_temp("fly_cfd_inside.toml", inside) + " -o " + c_dir +
                                " --wingbeats 0.05");
  ASSERT_EQ(rc.status, 0) << rc.out << rc.err;
  const CliResult ro = flapstab("fly " + testing::write_temp("fly_cfd_open.toml", open_loop) + " -o " + c_dir +
                                " --wingbeats 0.05");
  ASSERT_EQ(ro.status, 0) << ro.out << ro.err;
  EXPECT_NE(ro.out.find("hover state reused"), std::string::npos) << ro.out;
  EXPECT_NE(ro.out.find("reference: resumed"), std::string::npos) << ro.out;
  const CliResult rw = flapstab("fly " + testing::write_temp("fly_cfd_open.toml", open_loop) + " -o " + a +
                                " --wingbeats 0.05");
  ASSERT_EQ(rw.status, 0) << rw.out << rw.err;
  EXPECT_EQ(rw.out.find("hover state reused"), std::string::npos) << rw.out;  // another grid: the hover run afresh
}

// The fine box re-planned in a coupled flight (the body started 50 mm forward: a part within half the room of 0.4 R):
// the event printed and in run.json, and a flight stopped after the re-plan and extended from its checkpoint (whose
// header holds the box's shift) equal to the straight flight bit for bit. A cfd_replan that is not a boolean is
// refused naming the key.
TEST(FlyCli, CfdFlightReplansTheFineBoxAndResumesOnTheNewGrid) {
  const std::string text = tiny_cfd_case_text() +
                           "\n[flight]\ndof = \"longitudinal\"\nstart = \"rest\"\nsamples_per_wingbeat = 20\n"
                           "[flight.perturbation]\nx_m = 0.05\n";
  const std::string path = testing::write_temp("fly_cfd_replan.toml", text);
  const std::string a = fresh_dir("fly_cfd_replan_a"), b = fresh_dir("fly_cfd_replan_b");
  const CliResult ra = flapstab("fly " + path + " -o " + a + " --wingbeats 0.2");
  ASSERT_EQ(ra.status, 0) << ra.out << ra.err;
  EXPECT_NE(ra.out.find("re-planned around the body"), std::string::npos) << ra.out;
  EXPECT_NE(ra.out.find("flight: the fine box re-planned at wingbeat 0.000"), std::string::npos) << ra.out;
  std::ifstream in(fs::path(a) / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j["cfd"]["replanning"].get<bool>());
  ASSERT_GE(j["cfd"]["replans"]["flight"].size(), 1u) << j["cfd"].dump();
  const auto& e = j["cfd"]["replans"]["flight"][0];
  EXPECT_GT(e["shift_cells"]["hi"][0].get<int>(), 0) << e.dump();  // forward
  EXPECT_GT(e["fine_box_m"][1][0].get<double>(), j["cfd"]["fine_box_m"][1][0].get<double>());
  const CliResult rb1 = flapstab("fly " + path + " -o " + b + " --wingbeats 0.1");
  ASSERT_EQ(rb1.status, 0) << rb1.out << rb1.err;
  const CliResult rb2 = flapstab("fly " + path + " -o " + b + " --wingbeats 0.2");
  ASSERT_EQ(rb2.status, 0) << rb2.out << rb2.err;
  EXPECT_NE(rb2.out.find("resumed from"), std::string::npos) << rb2.out;
  std::ifstream jb(fs::path(b) / "run.json");
  const nlohmann::json k = nlohmann::json::parse(jb);
  // The checkpoint's header kept the earlier re-plan (its wall time aside).
  nlohmann::json ea = j["cfd"]["replans"]["flight"], eb = k["cfd"]["replans"]["flight"];
  for (auto* list : {&ea, &eb})
    for (auto& ev : *list) ev.erase("seconds");
  EXPECT_EQ(ea, eb);
  EXPECT_EQ(slurp(fs::path(a) / "steps.csv"), slurp(fs::path(b) / "steps.csv"));
  const std::string bad_text = replaced(text, "start = \"rest\"", "start = \"rest\"\ncfd_replan = \"yes\"");
  const CliResult bad = flapstab("fly " + testing::write_temp("fly_cfd_replan_bad.toml", bad_text) + " -o " +
                                 fresh_dir("fly_cfd_replan_bad"));
  EXPECT_EQ(bad.status, 2) << bad.out << bad.err;
  EXPECT_NE(bad.err.find("flight.cfd_replan"), std::string::npos) << bad.err;
}

// The wingbeat frequency as the coupled flight's actuator (a pitch controller on frequency_hz): it runs, its command
// moves, and a flight extended from its checkpoint (whose header keeps the wings' integrated phase) equals the
// straight one byte for byte.
TEST(FlyCli, CfdFrequencyControlResumesExactly) {
  const std::string text = tiny_cfd_case_text() +
                           "\n[flight]\ndof = \"longitudinal\"\nstart = \"rest\"\nsamples_per_wingbeat = 20\n"
                           "[flight.perturbation]\nq_deg_s = 50.0\n"
                           "\n[control]\ntype = \"pitch\"\n[control.pitch]\nactuator = \"frequency_hz\"\n"
                           "pitch_gain = 0.5\nrate_gain_s = 0.01\npitch_latency_s = 0.001\nrate_latency_s = 0.001\n"
                           "limit_deg = 5\n";
  const std::string path = testing::write_temp("fly_cfd_frequency.toml", text);
  const std::string a = fresh_dir("fly_cfd_freq_a"), b = fresh_dir("fly_cfd_freq_b");
  const CliResult ra = flapstab("fly " + path + " -o " + a + " --wingbeats 0.2");
  ASSERT_EQ(ra.status, 0) << ra.out << ra.err;
  EXPECT_NE(ra.out.find("pitch feedback on frequency_hz"), std::string::npos) << ra.out;
  std::ifstream st(fs::path(a) / "steps.csv");
  std::string header, line;
  std::getline(st, header);
  ASSERT_NE(header.find(",command_frequency_hz"), std::string::npos) << header;
  double largest = 0;
  while (std::getline(st, line)) largest = std::max(largest, std::abs(std::stod(line.substr(line.rfind(',') + 1))));
  EXPECT_GT(largest, 0.01);  // Hz
  ASSERT_EQ(flapstab("fly " + path + " -o " + b + " --wingbeats 0.1").status, 0);
  const CliResult rb = flapstab("fly " + path + " -o " + b + " --wingbeats 0.2");
  ASSERT_EQ(rb.status, 0) << rb.out << rb.err;
  EXPECT_NE(rb.out.find("resumed from"), std::string::npos) << rb.out;
  EXPECT_EQ(slurp(fs::path(a) / "steps.csv"), slurp(fs::path(b) / "steps.csv"));
}

// [flight] cfd_reference = "closed-loop": the reference flight flies under the controller too, and both flights'
// commands are the law applied to their own deviation from the tethered hover (no latency here: the command of a
// step is -(K_theta theta + K_q q) of that step's state, in degrees). A reference flown under a controller is not
// reused by an open-loop-reference run (its checkpoint is keyed by the controller).
TEST(FlyCli, CfdClosedLoopReferenceFliesUnderTheController) {
  std::string text = tiny_cfd_case_text();
  const double k_theta = 0.5, k_q = 0.005;
  const std::string control = "\n[control]\ntype = \"pitch\"\n[control.pitch]\nactuator = \"stroke_mean_deg\"\n"
                              "pitch_gain = 0.5\nrate_gain_s = 0.005\npitch_latency_s = 0\nrate_latency_s = 0\n"
                              "limit_deg = 5\n";
  const std::string flight = "\n[flight]\ndof = \"longitudinal\"\nsamples_per_wingbeat = 20\n";
  const std::string closed =
      text + flight + "cfd_reference = \"closed-loop\"\n[flight.perturbation]\nq_deg_s = 50.0\n" + control;
  const std::string dir = fresh_dir("fly_cfd_closed_ref");
  const CliResult r = flapstab("fly " + testing::write_temp("fly_cfd_closed_ref.toml", closed) + " -o " + dir +
                               " --wingbeats 0.25");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("both flights fly under it"), std::string::npos) << r.out;
  std::ifstream in(fs::path(dir) / "run.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["flight"]["cfd_reference"], "closed-loop");
  EXPECT_EQ(j["flight"]["controller"]["reference_flight"], "closed loop");
  EXPECT_NE(std::string(j["flight"]["controller"]["senses"]).find("tethered hover"), std::string::npos);
  // Each flight's commands against the law on its own state (columns: t, step, wingbeat, cfl, then x y z u v w p q r
  // phi theta psi; the command last).
  auto worst_error = [&](const fs::path& csv, double& largest) {
    std::ifstream st(csv);
    std::string line;
    std::getline(st, line);
    EXPECT_NE(line.find(",command_stroke_mean_deg"), std::string::npos) << line;
    double worst = 0;
    int rows = 0, unclamped = 0;
    for (; std::getline(st, line); ++rows) {
      std::vector<double> v;
      std::stringstream ss(line);
      for (std::string cell; std::getline(ss, cell, ',');) v.push_back(std::stod(cell));
      const double deg = 180 / M_PI;
      const double raw = -(k_theta * v.at(4 + 10) * deg + k_q * v.at(4 + 7) * deg), law = std::clamp(raw, -5.0, 5.0);
      unclamped += std::abs(raw) < 5.0;
      worst = std::max(worst, std::abs(v.back() - law));
      largest = std::max(largest, std::abs(v.back()));
    }
    EXPECT_EQ(rows, 31) << csv;  // 30 steps and the start
    EXPECT_GE(unclamped, 5) << csv;  // the law is checked inside the limits, not only at them
    return worst;
  };
  double largest_ref = 0, largest_flight = 0;
  const double e_ref = worst_error(fs::path(dir) / "reference_checkpoint.csv", largest_ref);
  const double e_flight = worst_error(fs::path(dir) / "steps.csv", largest_flight);
  std::printf("  closed-loop reference: command error %.1e deg (largest command %.3f deg), flight %.1e deg "
              "(%.3f deg)\n", e_ref, largest_ref, e_flight, largest_flight);
  EXPECT_LT(e_ref, 1e-9);
  EXPECT_LT(e_flight, 1e-9);
  EXPECT_GT(largest_ref, 1e-4);    // the reference flight's own rocking is fed back
  EXPECT_GT(largest_flight, 0.2);  // 50 deg/s x 0.005 s = 0.25 deg at the start
  // The default (open-loop reference) does not continue the closed-loop reference.
  const std::string open = text + flight + "[flight.perturbation]\nq_deg_s = 50.0\n" + control;
  const CliResult ro = flapstab("fly " + testing::write_temp("fly_cfd_open_ref.toml", open) + " -o " + dir +
                                " --wingbeats 0.05");
  ASSERT_EQ(ro.status, 0) << ro.out << ro.err;
  EXPECT_NE(ro.out.find("reference: " + dir + "/reference_checkpoint.h5 is of another case"), std::string::npos)
      << ro.out;
  // A value that is neither: refused, naming the key.
  const std::string bad = replaced(closed, "cfd_reference = \"closed-loop\"", "cfd_reference = \"closed\"");
  const CliResult rb = flapstab("fly " + testing::write_temp("fly_cfd_bad_ref.toml", bad) + " -o " +
                                fresh_dir("fly_cfd_bad_ref"));
  EXPECT_NE(rb.status, 0);
  EXPECT_NE(rb.err.find("cfd_reference"), std::string::npos) << rb.err;
}

}  // namespace
}  // namespace flapstab
