// Tests of the derivative-table reader and writer (core/derivative_table.cpp, docs/derivative-table.md).
#include "core/derivative_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "core/errors.hpp"

namespace fs = std::filesystem;
using namespace flapstab;

namespace {

// A complete, valid table; tests edit one line of it at a time.
const std::string kGood = R"(# test table
source = "unit test"

[reference]
U = 4.5
c = 0.004
S_t = 1e-4
rho = 1.225
frequency = 155

[mass]
m = 1.75e-4
Ixx = 1.5e-9
Iyy = 4.0e-9
Izz = 3.5e-9
Ixz = 0.5e-9

[derivatives.longitudinal]
Xu = -0.8
Xw = 0.05
Xq = -0.1
Zu = -0.03
Zw = -1.0
Zq = -0.03
Mu = 2.4
Mw = -0.2
Mq = -0.9

[derivatives.lateral]
Yv = -0.7
Yp = 0.1
Yr = 0.02
Lv = 1.5
Lp = -0.9
Lr = 0.1
Nv = 0.05
Np = -0.1
Nr = -0.6
)";

class DerivativeTableFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("flapstab_dt_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& text, const std::string& name = "table.toml") {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  // kGood with the first occurrence of `from` replaced by `to`.
  std::string edited(const std::string& from, const std::string& to) {
    std::string s = kGood;
    const auto at = s.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) s.replace(at, from.size(), to);
    return write(s);
  }
  // Reads `path` expecting an InputError naming the file and `key`; returns the message.
  std::string expect_error(const std::string& path, const std::string& key) {
    try {
      read_derivative_table(path);
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.key(), key) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      return e.what();
    }
    ADD_FAILURE() << "no InputError for key '" << key << "'";
    return {};
  }
  fs::path dir_;
};

bool bitwise_equal(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST(DerivativeNames, IndexAndSections) {
  DerivativeTable t;
  t.at("Mq") = 1.5;
  EXPECT_EQ(t.nd(4, 4), 1.5);  // rows X Y Z L M N, columns u v w p q r
  t.at("Lv") = 2.5;
  EXPECT_EQ(t.nd(3, 1), 2.5);
  EXPECT_EQ(derivative_name(2, 5), "Zr");
  EXPECT_THROW(t.at("Qq"), std::out_of_range);
  EXPECT_THROW(t.at("Xuu"), std::out_of_range);
  EXPECT_EQ(longitudinal_derivative_names().size(), 9u);
  EXPECT_EQ(lateral_derivative_names().size(), 9u);
  EXPECT_EQ(coupling_derivative_names().size(), 18u);  // 36 - 9 - 9
}

TEST_F(DerivativeTableFile, ReadsAGoodTable) {
  const auto path = write(kGood);
  const DerivativeTable t = read_derivative_table(path);
  EXPECT_EQ(t.source, "unit test");
  EXPECT_EQ(t.reference.U, 4.5);
  EXPECT_EQ(t.reference.frequency, 155.0);  // an integer is accepted as a number
  EXPECT_EQ(t.reference.g, standard_gravity);  // optional, defaults to standard gravity
  EXPECT_EQ(t.mass.Ixz, 0.5e-9);
  EXPECT_EQ(t.at("Mu"), 2.4);
  EXPECT_EQ(t.at("Nr"), -0.6);
  EXPECT_EQ(t.at("Xv"), 0.0);
  EXPECT_TRUE(t.has_longitudinal);
  EXPECT_TRUE(t.has_lateral);
  EXPECT_FALSE(t.has_coupling);
}

TEST_F(DerivativeTableFile, SourceDefaultsToPathAndSectionsMayBeAbsent) {
  std::string s = kGood.substr(0, kGood.find("[derivatives.lateral]"));
  s.replace(s.find("source = \"unit test\"\n"), 21, "");
  const auto path = write(s);
  const DerivativeTable t = read_derivative_table(path);
  EXPECT_EQ(t.source, path);
  EXPECT_TRUE(t.has_longitudinal);
  EXPECT_FALSE(t.has_lateral);
}

TEST_F(DerivativeTableFile, LongitudinalOnlyTableNeedsNoRollYawInertia) {
  // Published longitudinal tables give m and Iyy only (e.g. Sun & Xiong 2005).
  std::string s = kGood.substr(0, kGood.find("[derivatives.lateral]"));
  for (const char* k : {"Ixx = 1.5e-9\n", "Izz = 3.5e-9\n", "Ixz = 0.5e-9\n"}) s.replace(s.find(k), std::strlen(k), "");
  const DerivativeTable t = read_derivative_table(write(s));
  EXPECT_EQ(t.mass.Ixx, 0.0);
  EXPECT_EQ(t.mass.Iyy, 4.0e-9);
}

TEST_F(DerivativeTableFile, CouplingSection) {
  const auto path = write(kGood + "\n[derivatives.coupling]\nXv = 0.25\nLu = -0.5\nMp = 3\n");
  const DerivativeTable t = read_derivative_table(path);
  EXPECT_TRUE(t.has_coupling);
  EXPECT_EQ(t.at("Xv"), 0.25);
  EXPECT_EQ(t.at("Lu"), -0.5);
  EXPECT_EQ(t.at("Mp"), 3.0);
  EXPECT_EQ(t.at("Nq"), 0.0);  // coupling entries are optional
}

TEST_F(DerivativeTableFile, RoundTripIsExact) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> mant(-1, 1);
  std::uniform_int_distribution<int> expo(-300, 300);
  auto any = [&] { return std::ldexp(mant(rng), expo(rng)); };
  auto positive = [&] { return std::abs(any()) + std::numeric_limits<double>::min(); };
  for (int trial = 0; trial < 50; ++trial) {
    DerivativeTable t;
    t.source = "round \"trip\" \\ test\twith tab";
    t.reference = {positive(), positive(), positive(), positive(), positive(), positive()};
    t.mass.m = positive();
    t.mass.Iyy = positive();
    t.mass.Ixx = 1.0 + positive();
    t.mass.Izz = 1.0 + positive();
    t.mass.Ixz = trial == 0 ? -0.0 : 0.5 * mant(rng);  // |Ixz| < 1 < sqrt(Ixx Izz)
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) t.nd(r, c) = (trial == 1 && r == 0) ? 1.0 / 3.0 : any();
    t.has_longitudinal = t.has_lateral = t.has_coupling = true;

    const auto path = write(derivative_table_toml(t), "rt.toml");
    const DerivativeTable u = read_derivative_table(path);
    EXPECT_EQ(u.source, t.source);
    for (auto [a, b] : {std::pair{u.reference.U, t.reference.U}, {u.reference.c, t.reference.c},
                        {u.reference.S_t, t.reference.S_t}, {u.reference.rho, t.reference.rho},
                        {u.reference.frequency, t.reference.frequency}, {u.reference.g, t.reference.g},
                        {u.mass.m, t.mass.m}, {u.mass.Ixx, t.mass.Ixx}, {u.mass.Iyy, t.mass.Iyy},
                        {u.mass.Izz, t.mass.Izz}, {u.mass.Ixz, t.mass.Ixz}})
      EXPECT_TRUE(bitwise_equal(a, b)) << a << " vs " << b;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) EXPECT_TRUE(bitwise_equal(u.nd(r, c), t.nd(r, c))) << derivative_name(r, c);
    EXPECT_TRUE(u.has_longitudinal && u.has_lateral && u.has_coupling);
  }
}

TEST_F(DerivativeTableFile, WriterHeaderStatesConventions) {
  DerivativeTable t = read_derivative_table(write(kGood));
  const std::string s = derivative_table_toml(t);
  for (const char* needle : {"x forward", "z down", "1/2 rho U^2 S_t", "[u, w, q, theta]", "[v, p, r, phi]",
                             "[u, v, w, p, q, r, phi, theta]", "Ixz = int x z dm", "kg m^2"})
    EXPECT_NE(s.find(needle), std::string::npos) << needle;
  // Without coupling entries the writer emits no coupling section (flags round-trip too).
  EXPECT_EQ(s.find("[derivatives.coupling]"), std::string::npos);
  const auto out = (dir_ / "out.toml").string();
  write_derivative_table(t, out);
  const DerivativeTable u = read_derivative_table(out);
  EXPECT_FALSE(u.has_coupling);
  EXPECT_EQ(u.nd, t.nd);
}

TEST_F(DerivativeTableFile, MissingFile) {
  const auto path = (dir_ / "nope.toml").string();
  const auto msg = expect_error(path, "");
  EXPECT_NE(msg.find("not found"), std::string::npos);
}

TEST_F(DerivativeTableFile, SyntaxErrorGivesLine) {
  const auto path = edited("Zw = -1.0", "Zw = = -1.0");
  const auto msg = expect_error(path, "");
  // kGood's "Zw" line is line 23 of the file.
  EXPECT_NE(msg.find("line 23"), std::string::npos) << msg;
}

TEST_F(DerivativeTableFile, MissingSectionsAndEntries) {
  const auto ref_block = kGood.substr(kGood.find("[reference]"), kGood.find("[mass]") - kGood.find("[reference]"));
  const auto mass_block = kGood.substr(kGood.find("[mass]"), kGood.find("[derivatives") - kGood.find("[mass]"));
  expect_error(edited(ref_block, ""), "reference");
  expect_error(edited(mass_block, ""), "mass");
  expect_error(edited("[reference]", "[referenc]"), "referenc");  // a misspelt section is unknown
  expect_error(edited("U = 4.5\n", ""), "reference.U");
  expect_error(edited("frequency = 155\n", ""), "reference.frequency");
  expect_error(edited("m = 1.75e-4\n", ""), "mass.m");
  expect_error(edited("Iyy = 4.0e-9\n", ""), "mass.Iyy");
  // With a lateral section, roll/yaw inertia and Ixz are required.
  expect_error(edited("Ixx = 1.5e-9\n", ""), "mass.Ixx");
  expect_error(edited("Ixz = 0.5e-9\n", ""), "mass.Ixz");
  expect_error(edited("Mq = -0.9\n", ""), "derivatives.longitudinal.Mq");
  const auto msg = expect_error(edited("Nr = -0.6\n", ""), "derivatives.lateral.Nr");
  EXPECT_NE(msg.find("missing"), std::string::npos);
}

TEST_F(DerivativeTableFile, NonNumericAndNonFinite) {
  auto msg = expect_error(edited("Xu = -0.8", "Xu = \"-0.8\""), "derivatives.longitudinal.Xu");
  EXPECT_NE(msg.find("not a number"), std::string::npos) << msg;
  expect_error(edited("Lp = -0.9", "Lp = true"), "derivatives.lateral.Lp");
  expect_error(edited("c = 0.004", "c = [0.004]"), "reference.c");
  msg = expect_error(edited("Mq = -0.9", "Mq = nan"), "derivatives.longitudinal.Mq");
  EXPECT_NE(msg.find("not finite"), std::string::npos) << msg;
  expect_error(edited("Zw = -1.0", "Zw = -inf"), "derivatives.longitudinal.Zw");
  expect_error(edited("Ixz = 0.5e-9", "Ixz = inf"), "mass.Ixz");
}

TEST_F(DerivativeTableFile, NonPositiveMassInertiaAndReferences) {
  expect_error(edited("m = 1.75e-4", "m = 0"), "mass.m");
  expect_error(edited("m = 1.75e-4", "m = -1.75e-4"), "mass.m");
  expect_error(edited("Ixx = 1.5e-9", "Ixx = 0.0"), "mass.Ixx");
  expect_error(edited("Iyy = 4.0e-9", "Iyy = -4.0e-9"), "mass.Iyy");
  expect_error(edited("Izz = 3.5e-9", "Izz = -1"), "mass.Izz");
  for (const auto& [line, key] : std::vector<std::pair<std::string, std::string>>{
           {"U = 4.5", "reference.U"}, {"c = 0.004", "reference.c"}, {"S_t = 1e-4", "reference.S_t"},
           {"rho = 1.225", "reference.rho"}, {"frequency = 155", "reference.frequency"}}) {
    const std::string name = line.substr(0, line.find(' '));
    expect_error(edited(line, name + " = 0"), key);
    expect_error(edited(line, name + " = -2.5"), key);
  }
}

TEST_F(DerivativeTableFile, InertiaMustBePositiveDefinite) {
  // Ixx Izz = 5.25e-18; Ixz^2 = 6.25e-18 > that.
  const auto msg = expect_error(edited("Ixz = 0.5e-9", "Ixz = -2.5e-9"), "mass.Ixz");
  EXPECT_NE(msg.find("positive definite"), std::string::npos) << msg;
  // A negative Ixz that keeps the matrix positive definite is fine.
  EXPECT_NO_THROW(read_derivative_table(edited("Ixz = 0.5e-9", "Ixz = -2.0e-9")));
}

TEST_F(DerivativeTableFile, UnknownKeysAreErrors) {
  // A typo is reported as the unknown key, not as the entry it failed to provide.
  expect_error(edited("Xq = -0.1", "Xqq = -0.1"), "derivatives.longitudinal.Xqq");
  expect_error(edited("Xq = -0.1", "Xq = -0.1\nXqq = -0.1"), "derivatives.longitudinal.Xqq");
  expect_error(edited("S_t = 1e-4", "St = 1e-4"), "reference.St");
  const auto msg = expect_error(edited("Mq = -0.9\n", "Mq = -0.9\nYv = 1\n"), "derivatives.longitudinal.Yv");
  EXPECT_NE(msg.find("derivatives.lateral"), std::string::npos) << msg;
  expect_error(edited("rho = 1.225", "rho = 1.225\nnu = 1.5e-5"), "reference.nu");
  expect_error(edited("Iyy = 4.0e-9", "Iyy = 4.0e-9\nIxy = 0"), "mass.Ixy");
  expect_error(write(kGood + "\n[derivatives.lateal]\nYv = 1\n"), "derivatives.lateal");
  expect_error(write(kGood + "\n[trim]\nx = 1\n"), "trim");
  expect_error(write(kGood + "\n[derivatives.coupling]\nXu = 1\n"), "derivatives.coupling.Xu");
}

// [derivatives.control.<parameter>]: read with the parameter's unit, written back bit for bit, unknown parameters
// and keys refused.
TEST_F(DerivativeTableFile, ControlSectionRoundTripAndErrors) {
  const auto path = write(kGood + "\n[derivatives.control.stroke_plane_deg]\nX = -0.0427827\nM = 0.0129256\n"
                                  "[derivatives.control.frequency_hz]\nZ = -0.0123\n");
  const DerivativeTable t = read_derivative_table(path);
  ASSERT_EQ(t.control.size(), 2u);
  const ControlDerivative* sp = nullptr;
  const ControlDerivative* fr = nullptr;
  for (const auto& c : t.control) (c.parameter == "stroke_plane_deg" ? sp : fr) = &c;
  ASSERT_TRUE(sp && fr);
  EXPECT_EQ(sp->unit, "deg");
  EXPECT_EQ(fr->unit, "Hz");
  EXPECT_EQ(sp->nd(0), -0.0427827);
  EXPECT_EQ(sp->nd(4), 0.0129256);
  EXPECT_EQ(sp->nd(2), 0.0);  // missing entries are 0
  EXPECT_EQ(fr->nd(2), -0.0123);
  const auto back = write(derivative_table_toml(t));
  const DerivativeTable u = read_derivative_table(back);
  ASSERT_EQ(u.control.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k)
    for (int i = 0; i < 6; ++i) {
      const ControlDerivative& a = t.control[k];
      const auto it = std::find_if(u.control.begin(), u.control.end(), [&](const auto& c) { return c.parameter == a.parameter; });
      ASSERT_NE(it, u.control.end());
      EXPECT_TRUE(bitwise_equal(a.nd(i), it->nd(i)));
    }
  expect_error(write(kGood + "\n[derivatives.control.wing_twist_deg]\nX = 1\n"), "derivatives.control.wing_twist_deg");
  expect_error(write(kGood + "\n[derivatives.control.stroke_plane_deg]\nXu = 1\n"),
               "derivatives.control.stroke_plane_deg.Xu");
}

