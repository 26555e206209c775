// Tests of the derivative-table reader and writer (core/derivative_table.cpp, docs/derivative-table.md).
#include "core/derivative_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <charconv>
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
  // Derivatives within the reader's sensible range |D| <= 1e4 (2^13 = 8192), down to 2^-300.
  std::uniform_int_distribution<int> expo_d(-300, 13);
  auto derivative = [&] { return std::ldexp(mant(rng), expo_d(rng)); };
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
      for (int c = 0; c < 6; ++c) t.nd(r, c) = (trial == 1 && r == 0) ? 1.0 / 3.0 : derivative();
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
                             "[u, v, w, p, q, r, phi, theta]", "Ixz = int x z dm", "kg m^2", "time = \"chord\""})
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
  // Finite but absurd: refused with the key, the value printed short.
  msg = expect_error(edited("Mq = -0.9", "Mq = 1e300"), "derivatives.longitudinal.Mq");
  EXPECT_NE(msg.find("1e+300 is outside the physically sensible range"), std::string::npos) << msg;
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


// ---- Time conventions ([reference] time) and the non-dimensional mass set ([mass] *_plus) ----

namespace {

// kGood's physical system restated in the wingbeat convention with the non-dimensional mass set, by the formulas
// of docs/derivative-table.md written out here independently of the reader: T = 1/n, k = c / (U T);
// rate derivatives D_w = k D_c; m+ = m / (1/2 rho U S_t T); I+ = I / (1/2 rho U^2 S_t c T^2); g+ = g T / U.
struct WingbeatForm {
  double U = 4.5, c = 0.004, S_t = 1e-4, rho = 1.225, n = 155, g = standard_gravity;
  double T() const { return 1.0 / n; }
  double k() const { return c / (U * T()); }
  double mass_scale() const { return 0.5 * rho * U * S_t * T(); }
  double inertia_scale() const { return 0.5 * rho * U * U * S_t * c * T() * T(); }
};

// Shortest text that reads back as exactly v.
std::string num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string wingbeat_text(const WingbeatForm& w) {
  const double k = w.k(), ms = w.mass_scale(), is = w.inertia_scale();
  return "source = \"kGood in the wingbeat convention\"\n\n[reference]\ntime = \"wingbeat\"\nU = " + num(w.U) +
         "\nc = " + num(w.c) + "\nS_t = " + num(w.S_t) + "\nrho = " + num(w.rho) + "\nfrequency = " + num(w.n) +
         "\n\n[mass]\nm_plus = " + num(1.75e-4 / ms) + "\nIxx_plus = " + num(1.5e-9 / is) +
         "\nIyy_plus = " + num(4.0e-9 / is) + "\nIzz_plus = " + num(3.5e-9 / is) + "\nIxz_plus = " + num(0.5e-9 / is) +
         "\ng_plus = " + num(w.g * w.T() / w.U) +
         "\n\n[derivatives.longitudinal]\nXu = -0.8\nXw = 0.05\nXq = " + num(-0.1 * k) +
         "\nZu = -0.03\nZw = -1.0\nZq = " + num(-0.03 * k) + "\nMu = 2.4\nMw = -0.2\nMq = " + num(-0.9 * k) +
         "\n\n[derivatives.lateral]\nYv = -0.7\nYp = " + num(0.1 * k) + "\nYr = " + num(0.02 * k) +
         "\nLv = 1.5\nLp = " + num(-0.9 * k) + "\nLr = " + num(0.1 * k) + "\nNv = 0.05\nNp = " + num(-0.1 * k) +
         "\nNr = " + num(-0.6 * k) + "\n";
}

// A longitudinal-only table in the given convention with the non-dimensional mass set.
std::string nd_longitudinal(const std::string& time_line) {
  return time_line + R"(
[reference]
U = 4.5
c = 0.004
S_t = 1e-4
rho = 1.225
frequency = 155

[mass]
m_plus = 714.0
Iyy_plus = 1020.0
g_plus = 0.0019

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
)";
}

// nd_longitudinal with `time` placed in [reference] (a top-level key would be unknown).
std::string nd_longitudinal_with_time(const std::string& value) {
  std::string s = nd_longitudinal("");
  s.replace(s.find("[reference]\n"), 12, "[reference]\ntime = " + value + "\n");
  return s;
}

void expect_rel(double got, double want, double tol, const char* what) {
  EXPECT_LE(std::abs(got - want), tol * std::abs(want)) << what << ": " << got << " vs " << want;
}

}  // namespace

TEST_F(DerivativeTableFile, TimeDefaultsToChordAndWriterStatesIt) {
  const DerivativeTable a = read_derivative_table(write(kGood));  // no time key: today's convention
  const DerivativeTable b = read_derivative_table(edited("[reference]\n", "[reference]\ntime = \"chord\"\n"));
  EXPECT_EQ(a.nd, b.nd);
  EXPECT_EQ(a.mass.m, b.mass.m);
  const std::string s = derivative_table_toml(a);
  EXPECT_NE(s.find("[reference]\ntime = \"chord\"\n"), std::string::npos) << s;
  const DerivativeTable c = read_derivative_table(write(s, "back.toml"));
  EXPECT_EQ(c.nd, a.nd);
}

// The reader turns a wingbeat-convention table with m+, I+, g+ into the internal one: every value as the formulas give.
TEST_F(DerivativeTableFile, WingbeatNondimensionalReadsAsTheSameSystem) {
  const WingbeatForm w;
  const DerivativeTable a = read_derivative_table(write(kGood));
  const DerivativeTable b = read_derivative_table(write(wingbeat_text(w), "wingbeat.toml"));
  constexpr double tol = 1e-14;
  expect_rel(b.mass.m, a.mass.m, tol, "m");
  expect_rel(b.mass.Ixx, a.mass.Ixx, tol, "Ixx");
  expect_rel(b.mass.Iyy, a.mass.Iyy, tol, "Iyy");
  expect_rel(b.mass.Izz, a.mass.Izz, tol, "Izz");
  expect_rel(b.mass.Ixz, a.mass.Ixz, tol, "Ixz");
  expect_rel(b.reference.g, a.reference.g, tol, "g");
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      if (a.nd(r, c) == 0) EXPECT_EQ(b.nd(r, c), 0.0) << derivative_name(r, c);
      else expect_rel(b.nd(r, c), a.nd(r, c), tol, derivative_name(r, c).c_str());
    }
  EXPECT_EQ(b.at("Xu"), -0.8);  // velocity derivatives hold no time: read unchanged
  EXPECT_EQ(b.at("Mw"), -0.2);
  EXPECT_EQ(b.reference.frequency, 155.0);
}

// The chord convention with m+, I+, g+: m = m+ (1/2 rho S_t c), I = I+ (1/2 rho S_t c^3), g = g+ U^2 / c.
TEST_F(DerivativeTableFile, ChordNondimensionalMassSet) {
  const DerivativeTable t = read_derivative_table(write(nd_longitudinal("")));
  const double ms = 0.5 * 1.225 * 1e-4 * 0.004;
  expect_rel(t.mass.m, 714.0 * ms, 1e-15, "m");
  expect_rel(t.mass.Iyy, 1020.0 * ms * 0.004 * 0.004, 1e-15, "Iyy");
  expect_rel(t.reference.g, 0.0019 * 4.5 * 4.5 / 0.004, 1e-15, "g");
  EXPECT_EQ(t.at("Mq"), -0.9);  // chord convention: derivatives as given
  EXPECT_EQ(t.mass.Ixx, 0.0);
}

// The control derivatives hold no time and are read unchanged in the wingbeat convention; rate derivatives
// scale by U / (c n).
TEST_F(DerivativeTableFile, WingbeatConvertsRateDerivativesOnly) {
  std::string s = nd_longitudinal_with_time("\"wingbeat\"") + "\n[derivatives.coupling]\nXp = 0.3\nLu = 0.2\n" +
                  "\n[derivatives.control.stroke_plane_deg]\nX = -0.04\nM = 0.013\n";
  // A coupling section needs the roll-yaw inertia too.
  s.replace(s.find("g_plus"), 6, "Ixx_plus = 400\nIzz_plus = 900\nIxz_plus = -50\ng_plus");
  const DerivativeTable t = read_derivative_table(write(s));
  const double k = 0.004 * 155 / 4.5;
  expect_rel(t.at("Mq"), -0.9 / k, 1e-15, "Mq");
  expect_rel(t.at("Xq"), -0.1 / k, 1e-15, "Xq");
  expect_rel(t.at("Xp"), 0.3 / k, 1e-15, "Xp");
  EXPECT_EQ(t.at("Lu"), 0.2);
  EXPECT_EQ(t.at("Zw"), -1.0);
  ASSERT_EQ(t.control.size(), 1u);
  EXPECT_EQ(t.control[0].nd(0), -0.04);
  EXPECT_EQ(t.control[0].nd(4), 0.013);
  // g = g+ U / T, m = m+ (1/2 rho U S_t T), Iyy = Iyy+ (1/2 rho U^2 S_t c T^2)
  const double T = 1.0 / 155;
  expect_rel(t.reference.g, 0.0019 * 4.5 / T, 1e-15, "g");
  expect_rel(t.mass.m, 714.0 * 0.5 * 1.225 * 4.5 * 1e-4 * T, 1e-15, "m");
  const double is = 0.5 * 1.225 * 4.5 * 4.5 * 1e-4 * 0.004 * T * T;
  expect_rel(t.mass.Iyy, 1020.0 * is, 1e-15, "Iyy");
  expect_rel(t.mass.Ixx, 400.0 * is, 1e-15, "Ixx");
  expect_rel(t.mass.Izz, 900.0 * is, 1e-15, "Izz");
  expect_rel(t.mass.Ixz, -50.0 * is, 1e-15, "Ixz");
}

// SI mass properties with wingbeat-convention derivatives: the mass is read as given, the rate derivatives converted.
TEST_F(DerivativeTableFile, WingbeatWithSiMass) {
  const DerivativeTable a = read_derivative_table(write(kGood));
  const DerivativeTable b = read_derivative_table(edited("[reference]\n", "[reference]\ntime = \"wingbeat\"\n"));
  EXPECT_EQ(b.mass.m, a.mass.m);
  EXPECT_EQ(b.mass.Ixz, a.mass.Ixz);
  EXPECT_EQ(b.reference.g, a.reference.g);
  const double k = 0.004 * 155 / 4.5;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      const double want = c >= 3 ? a.nd(r, c) / k : a.nd(r, c);  // columns p, q, r
      EXPECT_NEAR(b.nd(r, c), want, 1e-15 * std::abs(want)) << derivative_name(r, c);
    }
}

TEST_F(DerivativeTableFile, UnknownOrMistypedTimeConvention) {
  auto msg = expect_error(write(nd_longitudinal_with_time("\"period\"")), "reference.time");
  EXPECT_NE(msg.find("unknown time convention \"period\""), std::string::npos) << msg;
  EXPECT_NE(msg.find("\"wingbeat\""), std::string::npos) << msg;
  msg = expect_error(write(nd_longitudinal_with_time("1")), "reference.time");
  EXPECT_NE(msg.find("not a string"), std::string::npos) << msg;
  expect_error(write(nd_longitudinal_with_time("\"Wingbeat\"")), "reference.time");  // values are exact
  // time is a [reference] key: at the top level it is unknown.
  expect_error(write(nd_longitudinal("time = \"wingbeat\"\n")), "time");
}

TEST_F(DerivativeTableFile, SiAndNondimensionalMassSetsDoNotMix) {
  // An SI entry beside the non-dimensional set: the error names the non-dimensional key and the SI one.
  auto msg = expect_error(edited("m = 1.75e-4\n", "m = 1.75e-4\nm_plus = 714\n"), "mass.m_plus");
  EXPECT_NE(msg.find("mass.m"), std::string::npos) << msg;
  EXPECT_NE(msg.find("not both"), std::string::npos) << msg;
  std::string s = nd_longitudinal("");
  s.replace(s.find("Iyy_plus = 1020.0\n"), 18, "Iyy = 4.0e-9\n");
  msg = expect_error(write(s), "mass.m_plus");
  EXPECT_NE(msg.find("mass.Iyy"), std::string::npos) << msg;
  // SI g in [reference] with the non-dimensional set.
  s = nd_longitudinal("");
  s.replace(s.find("rho = 1.225\n"), 12, "rho = 1.225\ng = 9.81\n");
  msg = expect_error(write(s), "reference.g");
  EXPECT_NE(msg.find("g_plus"), std::string::npos) << msg;
  // g_plus alone marks the non-dimensional set too.
  expect_error(edited("Ixz = 0.5e-9\n", "Ixz = 0.5e-9\ng_plus = 0.002\n"), "mass.g_plus");
  // g in [mass] is unknown there, with a pointer to where it belongs.
  msg = expect_error(edited("Ixz = 0.5e-9\n", "Ixz = 0.5e-9\ng = 9.81\n"), "mass.g");
  EXPECT_NE(msg.find("[reference]"), std::string::npos) << msg;
}

TEST_F(DerivativeTableFile, NondimensionalSetEntriesAndReferences) {
  auto without = [&](const std::string& s, const std::string& line) {
    std::string t = s;
    const auto at = t.find(line);
    EXPECT_NE(at, std::string::npos) << line;
    t.erase(at, line.size());
    return write(t);
  };
  const std::string lon = nd_longitudinal("");
  expect_error(without(lon, "g_plus = 0.0019\n"), "mass.g_plus");
  expect_error(without(lon, "Iyy_plus = 1020.0\n"), "mass.Iyy_plus");
  expect_error(without(lon, "m_plus = 714.0\n"), "mass.m_plus");
  // Every reference quantity is needed to bring the set to SI; the message says how it is used.
  const std::string wb = nd_longitudinal_with_time("\"wingbeat\"");
  for (const auto& [line, key] : std::vector<std::pair<std::string, std::string>>{
           {"frequency = 155\n", "reference.frequency"}, {"rho = 1.225\n", "reference.rho"},
           {"S_t = 1e-4\n", "reference.S_t"}, {"U = 4.5\n", "reference.U"}, {"c = 0.004\n", "reference.c"}}) {
    const auto msg = expect_error(without(wb, line), key);
    EXPECT_NE(msg.find("1/2 rho U S_t T"), std::string::npos) << msg;
  }
  const auto msg = expect_error(without(lon, "S_t = 1e-4\n"), "reference.S_t");
  EXPECT_NE(msg.find("1/2 rho S_t c"), std::string::npos) << msg;
  expect_error(write(std::string(lon).replace(lon.find("g_plus = 0.0019"), 15, "g_plus = 0")), "mass.g_plus");
  expect_error(write(std::string(lon).replace(lon.find("m_plus = 714.0"), 14, "m_plus = -714")), "mass.m_plus");
  // With a lateral section the roll-yaw set is required, and checked for positive definiteness, by its own names.
  const WingbeatForm w;
  const std::string full = wingbeat_text(w);
  const auto ixx = full.substr(full.find("Ixx_plus"), full.find('\n', full.find("Ixx_plus")) + 1 - full.find("Ixx_plus"));
  expect_error(without(full, ixx), "mass.Ixx_plus");
  const auto ixz = full.substr(full.find("Ixz_plus"), full.find('\n', full.find("Ixz_plus")) + 1 - full.find("Ixz_plus"));
  const auto msg2 = expect_error(write(std::string(full).replace(full.find(ixz), ixz.size(), "Ixz_plus = 1e6\n")),
                                 "mass.Ixz_plus");
  EXPECT_NE(msg2.find("positive definite"), std::string::npos) << msg2;
}
