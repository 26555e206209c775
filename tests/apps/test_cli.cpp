// End-to-end tests of the flapstab command: outputs, JSON keys, and bad input (message naming file and
// key, non-zero exit status, no output file).
#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <complex>
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
using testing::replace;
using testing::valid_case_text;
using testing::write_temp;

struct CliRun {
  int status;
  std::string err;
};

CliRun flapstab(const std::string& args) {
  const std::string errfile = write_temp("stderr.txt", "");
  const std::string cmd = std::string(FLAPSTAB_BINARY) + " " + args + " > /dev/null 2> " + errfile;
  const int rc = std::system(cmd.c_str());
  std::ifstream in(errfile);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, ss.str()};
}

// The same, run from the working directory `cwd`.
CliRun flapstab_in(const std::string& cwd, const std::string& args) {
  const std::string errfile = write_temp("stderr_in.txt", "");
  const std::string cmd = "cd '" + cwd + "' && " + std::string(FLAPSTAB_BINARY) + " " + args + " > /dev/null 2> " + errfile;
  const int rc = std::system(cmd.c_str());
  std::ifstream in(errfile);
  std::stringstream ss;
  ss << in.rdbuf();
  return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, ss.str()};
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

TEST(Cli, TrimHoverOnTheHawkmothWritesTheDocumentedJson) {
  const std::string out = write_temp("t.json", "");
  fs::remove(out);
  const CliRun r = flapstab("trim-hover " + std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml --json " + out);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = read_json(out);
  const auto& t = j.at("trim");
  EXPECT_TRUE(t.at("converged").get<bool>());
  EXPECT_LT(t.at("residuals").at("force_relative_to_weight").get<double>(), 1e-8);
  EXPECT_LT(t.at("residuals").at("moment_relative_to_weight_times_wing_length").get<double>(), 1e-8);
  EXPECT_GT(t.at("iterations").get<int>(), 0);
  ASSERT_FALSE(t.at("parameters").empty());
  for (const auto& p : t.at("parameters")) {
    EXPECT_FALSE(p.at("name").get<std::string>().empty());
    EXPECT_FALSE(p.at("unit").get<std::string>().empty());
    EXPECT_TRUE(p.at("value").is_number());
  }
  EXPECT_TRUE(j.contains("conventions") || j.contains("program"));
}

TEST(Cli, DerivativesWritesTomlAndJson) {
  const fs::path dir = fs::path(write_temp("x", "")).parent_path() / "der_out";
  fs::remove_all(dir);
  const CliRun r = flapstab("derivatives " + write_temp("d.toml", valid_case_text()) + " -q -o " + dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "derivatives.toml"));
  const auto j = read_json((dir / "derivatives.json").string());
  EXPECT_LT(j.at("derivatives").at("nondimensional").at("Xu").get<double>(), 0.0);
}

struct Bad {
  const char* label;
  const char* from;
  const char* to;
  const char* key;  // must appear in the message
};

class CliBadInput : public ::testing::TestWithParam<Bad> {};

TEST_P(CliBadInput, FailsWithMessageAndNoOutput) {
  const Bad b = GetParam();
  const std::string path = write_temp(std::string("cli_") + b.label + ".toml", replace(valid_case_text(), b.from, b.to));
  const std::string out = write_temp(std::string("cli_") + b.label + ".json", "");
  const fs::path dir = fs::path(out).parent_path() / (std::string("cli_dir_") + b.label);
  fs::remove(out);
  fs::remove_all(dir);
  for (const char* cmd : {"trim-hover", "derivatives"}) {
    const CliRun r = flapstab(std::string(cmd) + " " + path + " --json " + out + " -o " + dir.string());
    EXPECT_NE(r.status, 0) << cmd << " " << b.label;
    EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(b.key), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << cmd << " " << b.label;
    EXPECT_FALSE(fs::exists(dir)) << cmd << " " << b.label;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Inputs, CliBadInput,
    ::testing::Values(
        Bad{"missing_key", "mass_kg = 1.554e-3\n", "", "body.mass_kg"},
        Bad{"wrong_type", "frequency_hz = 26.0", "frequency_hz = \"26\"", "kinematics.frequency_hz"},
        Bad{"negative_mass", "mass_kg = 47e-6", "mass_kg = -47e-6", "wing.mass_kg"},
        Bad{"nan", "length_m = 0.0519", "length_m = nan", "wing.length_m"},
        Bad{"unknown_trim_parameter", "name = \"stroke_mean_deg\"", "name = \"stroke_offset_deg\"",
            "trim.parameter[1].name"},
        // Berman & Wang (2007) angle forms: K must lie in (0, 1), C be positive, the amplitude be given.
        Bad{"berman_wang_k_one", "cos_deg = [-60.0]\nsin_deg = [0.0]",
            "type = \"berman-wang\"\namplitude_deg = 60.0\nshape_k = 1.0", "kinematics.stroke.shape_k"},
        Bad{"berman_wang_c_zero", "cos_deg = [0.0]\nsin_deg = [-55.0]",
            "type = \"berman-wang\"\namplitude_deg = -55.0\nshape_c = 0.0", "kinematics.pitch.shape_c"},
        Bad{"berman_wang_no_amplitude", "cos_deg = [0.0]\nsin_deg = [-55.0]", "type = \"berman-wang\"\nshape_c = 2.0",
            "kinematics.pitch.amplitude_deg"}),
    [](const ::testing::TestParamInfo<Bad>& i) { return std::string(i.param.label); });

// Gravity enters the weight, the equations of motion and the non-dimensional g+. With g doubled and the trim moving
// the frequency, the quasi-steady hover is the same flight at sqrt(2) times the speed: loads ~ n^2 at fixed angles,
// so time scales by 1/sqrt(2) and every eigenvalue (1/s) by sqrt(2) exactly (dimensional similarity; 1e-6
// relative covers the trim tolerance and the derivatives' central differences, which scale with U).
TEST(Cli, DoubledGravityScalesTheEigenvaluesBySqrtTwo) {
  const std::string base = replace(replace(valid_case_text(), "name = \"stroke_amplitude_deg\"\nlower = 60.0\nupper = 170.0",
                                           "name = \"frequency_hz\"\nlower = 10.0\nupper = 80.0"),
                                   "[fluid]\n", "[environment]\ngravity_m_s2 = G\n\n[fluid]\n");
  auto eigenvalues = [&](const std::string& g) {
    const std::string path = write_temp("cli_gravity_" + g + ".toml", replace(base, "gravity_m_s2 = G", "gravity_m_s2 = " + g));
    const fs::path dir = fs::path(path).parent_path() / ("cli_gravity_dir_" + g);
    fs::remove_all(dir);
    const CliRun r = flapstab("stability " + path + " -q -o " + dir.string());
    EXPECT_EQ(r.status, 0) << r.err;
    std::vector<std::complex<double>> out;
    const auto j = read_json((dir / "stability.json").string()).at("stability");
    EXPECT_NEAR(j.at("reference").at("g").get<double>(), std::stod(g), 1e-12);
    for (const auto& m : j.at("longitudinal").at("modes")) {
      const auto& e = m.at("eigenvalue_per_s");
      out.emplace_back(e[0].get<double>(), e[1].get<double>());
    }
    std::sort(out.begin(), out.end(), [](auto a, auto b) { return a.real() < b.real() || (a.real() == b.real() && a.imag() < b.imag()); });
    return out;
  };
  const auto one = eigenvalues("9.80665"), two = eigenvalues("19.6133");
  ASSERT_EQ(one.size(), two.size());
  ASSERT_FALSE(one.empty());
  for (std::size_t i = 0; i < one.size(); ++i)
    EXPECT_LT(std::abs(two[i] - std::sqrt(2.0) * one[i]), 1e-6 * std::abs(two[i])) << two[i] << " vs sqrt 2 x " << one[i];
}

// --no-trim: derivatives, stability, floquet and analyze evaluate at the case's kinematics as they are, report the
// residual, and write it in their JSON. Check: a case written with the trimmed kinematics (the trim's own parameter
// values, 17 digits) evaluated with --no-trim has the trim's residual (below its 1e-10 tolerance; 1e-8 stated) and
// the trimmed case's derivatives (to 1e-9: the kinematics agree to round-off); the untrimmed case reports the same
// residual in every command.
TEST(Cli, NoTrimEvaluatesAtTheCaseKinematicsAndReportsTheResidual) {
  const std::string dir = fs::path(write_temp("nt_probe", "")).parent_path().string();
  const std::string base = write_temp("nt_base.toml", valid_case_text());
  const CliRun tr = flapstab("derivatives " + base + " -q --json " + dir + "/nt_trimmed.json");
  ASSERT_EQ(tr.status, 0) << tr.err;
  const auto trimmed = read_json(dir + "/nt_trimmed.json");
  const auto& p = trimmed.at("trim").at("parameters");
  ASSERT_EQ(p[0].at("name"), "stroke_amplitude_deg");
  char buf[256];
  std::snprintf(buf, sizeof buf, "mean_deg = %.17g\ncos_deg = [%.17g]", p[1].at("value").get<double>(),
                -0.5 * p[0].at("value").get<double>());
  std::string text = replace(valid_case_text(), "mean_deg = 0.0\ncos_deg = [-60.0]", buf);
  std::snprintf(buf, sizeof buf, "mean_deg = %.17g\ncos_deg = [0.0]", p[2].at("value").get<double>());
  text = replace(text, "mean_deg = 90.0\ncos_deg = [0.0]", buf);
  const std::string at_trim = write_temp("nt_at_trim.toml", text);
  const CliRun r = flapstab("derivatives " + at_trim + " --no-trim -q --json " + dir + "/nt_at_trim.json");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = read_json(dir + "/nt_at_trim.json");
  EXPECT_FALSE(j.at("trim").at("solved").get<bool>());
  EXPECT_LT(j.at("trim").at("residuals").at("force_relative_to_weight").get<double>(), 1e-8);
  EXPECT_LT(j.at("trim").at("residuals").at("moment_relative_to_weight_times_wing_length").get<double>(), 1e-8);
  for (const auto& [k, v] : trimmed.at("derivatives").at("nondimensional").items())
    if (v.is_number()) {
      EXPECT_NEAR(j.at("derivatives").at("nondimensional").at(k).get<double>(), v.get<double>(), 1e-9) << k;
    }

  // The untrimmed case: the same residual in derivatives, stability, floquet and analyze.
  const CliRun d = flapstab("derivatives " + base + " --no-trim -q --json " + dir + "/nt_d.json");
  ASSERT_EQ(d.status, 0) << d.err;
  const double residual = read_json(dir + "/nt_d.json").at("trim").at("residuals").at("force_relative_to_weight");
  EXPECT_GT(residual, 1e-3);  // the case's own kinematics do not balance the weight
  const CliRun s = flapstab("stability " + base + " --no-trim -q --json " + dir + "/nt_s.json");
  ASSERT_EQ(s.status, 0) << s.err;
  EXPECT_EQ(read_json(dir + "/nt_s.json").at("trim").at("residuals").at("force_relative_to_weight").get<double>(), residual);
  const CliRun f = flapstab("floquet " + base + " --no-trim -q --json " + dir + "/nt_f.json");
  ASSERT_EQ(f.status, 0) << f.err;
  const auto fj = read_json(dir + "/nt_f.json");
  EXPECT_FALSE(fj.at("cyclic_trim").at("solved").get<bool>());
  EXPECT_EQ(fj.at("residual").at("force_relative_to_weight").get<double>(), residual);
  EXPECT_TRUE(fj.at("longitudinal").at("routes").at("flow_sensitivity").is_null());
  const fs::path out = fs::path(dir) / "nt_analyze";
  fs::remove_all(out);
  const CliRun a = flapstab("analyze " + base + " --no-trim -q -o " + out.string());
  ASSERT_EQ(a.status, 0) << a.err;
  const auto aj = read_json((out / "results.json").string());
  EXPECT_EQ(aj.at("trim").at("residuals").at("force_relative_to_weight").get<double>(), residual);
  EXPECT_EQ(aj.at("verdict").get<std::string>().rfind("NOT TRIMMED", 0), 0u);
}

TEST(CliStatus, NoTrimWithADerivativeTableOrTheCfdModelIsBadInput) {
  const std::string table = std::string(FLAPSTAB_SOURCE_DIR) + "/data/examples/derivative_table_bumblebee.toml";
  const CliRun r = flapstab("stability --derivatives " + table + " --no-trim");
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("--no-trim"), std::string::npos) << r.err;
  const std::string cfd = write_temp("nt_cfd.toml", replace(valid_case_text(), "model = \"quasi-steady\"", "model = \"cfd\""));
  const fs::path out = fs::path(cfd).parent_path() / "nt_cfd_out";
  fs::remove_all(out);
  for (const char* cmd : {"derivatives", "stability", "floquet", "analyze"}) {
    const CliRun c = flapstab(std::string(cmd) + " " + cfd + " --no-trim -q -o " + out.string());
    EXPECT_EQ(c.status, 2) << cmd << ": " << c.err;
    EXPECT_NE(c.err.find("aero.model"), std::string::npos) << c.err;
    EXPECT_FALSE(fs::exists(out)) << cmd;
  }
}

// Bad input exits with status 2 (docs/user-guide.md), here for a Berman-Wang K >= 1.
TEST(CliStatus, BermanWangShapeOutOfRangeIsBadInput) {
  const std::string path = write_temp("cli_bw_status.toml", replace(valid_case_text(), "cos_deg = [-60.0]\nsin_deg = [0.0]",
                                                                    "type = \"berman-wang\"\namplitude_deg = 60.0\nshape_k = 1.5"));
  const CliRun r = flapstab("trim-hover " + path);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("kinematics.stroke.shape_k"), std::string::npos) << r.err;
}

// Infeasible trim: the stroke amplitude may not exceed 62 deg, far below what weight support needs.
TEST(Cli, InfeasibleTrimFailsWithoutOutput) {
  const std::string text = replace(replace(valid_case_text(), "lower = 60.0\nupper = 170.0", "lower = 60.0\nupper = 62.0"),
                                   "cos_deg = [-60.0]", "cos_deg = [-30.5]");
  const std::string path = write_temp("inf.toml", text), out = write_temp("inf.json", "");
  fs::remove(out);
  const CliRun r = flapstab("trim-hover " + path + " --json " + out);
  EXPECT_EQ(r.status, 3);
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("trim.parameter"), std::string::npos) << r.err;
  // It names the bound that holds the trim.
  EXPECT_NE(r.err.find("trim.parameter[0] (stroke_amplitude_deg) at its upper bound 62 deg"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Cli, AnalyzeWritesTheReport) {
  const fs::path dir = fs::path(write_temp("x", "")).parent_path() / "analyze_out";
  fs::remove_all(dir);
  const CliRun r = flapstab("analyze " + std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml -q -o " +
                            dir.string());
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* f : {"report.md", "report.html", "results.json", "derivatives.toml", "loads.csv"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  const auto j = read_json((dir / "results.json").string());
  for (const char* k : {"longitudinal", "lateral", "6dof"}) EXPECT_TRUE(j.at("stability").contains(k)) << k;
  // The derivative table it wrote reads back into `stability --derivatives`.
  const std::string out = (dir / "stab.json").string();
  const CliRun s = flapstab("stability --derivatives " + (dir / "derivatives.toml").string() +
                            " --model longitudinal -q --json " + out);
  ASSERT_EQ(s.status, 0) << s.err;
  const auto st = read_json(out).at("stability");
  EXPECT_EQ(st.at("state_order").size(), 4u);
  EXPECT_EQ(st.at("modes").size(), 3u);
  EXPECT_TRUE(st.at("modes")[0].contains("eigenvalue_nd"));
}

// A bad derivative table (missing entry, non-numeric, NaN, zero mass, negative inertia): message
// naming the file and the key, non-zero exit, no output.
TEST(Cli, BadDerivativeTableFailsWithoutOutput) {
  const std::string good = R"([reference]
U = 2.0
c = 0.018
S_t = 0.0019
rho = 1.225
frequency = 26.0
[mass]
m = 1.6e-3
Ixx = 1e-7
Iyy = 2e-7
Izz = 2e-7
Ixz = 0.0
[derivatives.longitudinal]
Xu = -1.8
Xw = -0.2
Xq = -0.8
Zu = -0.2
Zw = -1.8
Zq = -0.4
Mu = 1.9
Mw = 0.5
Mq = -1.1
)";
  struct Edit { const char* from; const char* to; const char* key; };
  for (const Edit& e : {Edit{"Zq = -0.4\n", "", "Zq"}, Edit{"Mu = 1.9", "Mu = \"big\"", "Mu"},
                        Edit{"Xu = -1.8", "Xu = nan", "Xu"}, Edit{"m = 1.6e-3", "m = 0.0", "m"},
                        Edit{"Iyy = 2e-7", "Iyy = -2e-7", "Iyy"}}) {
    const std::string path = write_temp("bad_table.toml", replace(good, e.from, e.to));
    const std::string out = write_temp("bad_table.json", "");
    fs::remove(out);
    const CliRun r = flapstab("stability --derivatives " + path + " --json " + out);
    EXPECT_NE(r.status, 0) << e.key;
    EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(e.key), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << e.key;
  }
  const std::string ok = write_temp("good_table.toml", good), out = write_temp("good_table.json", "");
  EXPECT_EQ(flapstab("stability --derivatives " + ok + " -q --json " + out).status, 0);
}

TEST(Cli, MissingCaseFileFails) {
  const CliRun r = flapstab("trim-hover /nonexistent/case.toml");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("/nonexistent/case.toml"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace flapstab

namespace flapstab {
namespace {

// Exit statuses as documented (flapstab --help footer, docs/user-guide.md): command-line errors are bad input.
TEST(CliStatus, CommandLineErrorsAreBadInput) {
  const std::string hawk = std::string(FLAPSTAB_SOURCE_DIR) + "/data/insects/hawkmoth.toml";
  EXPECT_EQ(flapstab("").status, 2);                                  // no subcommand
  EXPECT_EQ(flapstab("fly-away " + hawk).status, 2);                  // unknown subcommand
  EXPECT_EQ(flapstab("trim-hover /no/such/case.toml").status, 2);     // missing file
  EXPECT_EQ(flapstab("cfd " + hawk + " --cycles 0").status, 2);       // option out of range
  EXPECT_EQ(flapstab("stability " + hawk + " --model 7dof").status, 2);
  EXPECT_EQ(flapstab("--help").status, 0);
  EXPECT_EQ(flapstab("--version").status, 0);
}

// An empty [output] directory is refused when the case is read (before any computation), naming the key.
TEST(CliStatus, EmptyOutputDirectoryIsBadInput) {
  std::string text = valid_case_text();
  text += "\n[output]\ndirectory = \"\"\n";
  const std::string path = write_temp("empty_out.toml", text);
  const CliRun r = flapstab("analyze " + path);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("'output.directory'"), std::string::npos) << r.err;
}

// [output] directory: a relative path is taken from the working directory (docs/case-file.md), not from the
// case file's folder; -o overrides it.
TEST(CliStatus, RelativeOutputDirectoryIsTakenFromTheWorkingDirectory) {
  const fs::path base = fs::path(write_temp("x", "")).parent_path();
  const fs::path cases = base / "outdir_cases", work = base / "outdir_work";
  fs::remove_all(cases);
  fs::remove_all(work);
  fs::create_directories(cases);
  fs::create_directories(work);
  const std::string path = (cases / "rel.toml").string();
  std::ofstream(path) << valid_case_text() + "\n[output]\ndirectory = \"rel_out\"\n";
  const CliRun r = flapstab_in(work.string(), "analyze " + path + " -q");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(work / "rel_out" / "results.json"));
  EXPECT_FALSE(fs::exists(cases / "rel_out"));
}

// A derivative table without a section the requested analysis can use is bad input, not an empty success.
TEST(CliStatus, DerivativeTableWithoutSectionsIsBadInput) {
  const std::string path = write_temp("no_sections.toml",
                                      "[reference]\nU = 4.5\nc = 0.004\nS_t = 1e-4\nrho = 1.225\nfrequency = 155\n"
                                      "[mass]\nm = 1.75e-4\nIyy = 4e-9\n");
  const CliRun r = flapstab("stability --derivatives " + path);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("'derivatives'"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace flapstab
