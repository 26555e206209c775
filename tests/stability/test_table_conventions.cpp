// One physical system written in the two time conventions of a derivative table (docs/derivative-table.md: chord,
// t+ = t U / c with SI mass properties, flapstab's own; wingbeat, t+ = t / T with m+, I+, g+ as Sun's group prints
// them, e.g. Sun & Xiong 2005, J Exp Biol 208:447) reads to the same dimensional eigenvalues.
#include <gtest/gtest.h>

#include <charconv>
#include <complex>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/derivative_table.hpp"
#include "stability/analysis.hpp"
#include "stability/lti.hpp"
#include "stability_fixtures.hpp"

namespace fs = std::filesystem;
using namespace flapstab;
using namespace flapstab::test;

namespace {

// flapstab's own bumblebee table, as `flapstab derivatives data/insects/bumblebee.toml` wrote it (quasi-steady
// model, the trimmed hover of the model bumblebee of Sun & Xiong 2005; chord convention, SI mass properties),
// less its header comment and control sections.
const char* kBumblebee = R"toml(source = "data/insects/bumblebee.toml (flapstab cycle-averaged derivatives, quasi-steady (robofly))"

[reference]
time = "chord"
U = 3.2552322590736935
c = 0.00401
S_t = 0.00010586399999999999
rho = 1.225
frequency = 155.0
g = 9.80665

[mass]
m = 0.00017499979999999998
Ixx = 2.862536196699085e-09
Iyy = 3.6006461984315754e-09
Izz = 1.711645629251678e-09
Ixz = -1.227751347742532e-09

[derivatives.longitudinal]
Xu = -1.9548333345914914
Xw = -0.21141561671697515
Xq = 0.8471141964373744
Zu = 0.04082747005915695
Zw = -1.7564554382568114
Zq = -0.2454430176786215
Mu = 3.940033639482206
Mw = 0.4358599236365747
Mq = -4.001304680210708

[derivatives.lateral]
Yv = -0.602089766125998
Yp = -4.494488376417997
Yr = -0.5817284264393463
Lv = 3.0912581977562374
Lp = -13.156542322865981
Lr = -0.42755991897820234
Nv = 0.0975254791506499
Np = 2.169288180232521
Nr = -18.613171746646167

[derivatives.coupling]
Xv = 0.0
Xp = 0.0
Xr = 0.0
Yu = 0.0
Yw = 0.0
Yq = 0.0
Zv = 0.0
Zp = 0.0
Zr = 0.0
Lu = 0.0
Lw = 0.0
Lq = 0.0
Mv = 0.0
Mp = 0.0
Mr = 0.0
Nu = 0.0
Nw = 0.0
Nq = 0.0
)toml";

std::string num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// The same physical system in the wingbeat convention with the non-dimensional mass set, with the formulas of
// docs/derivative-table.md coded here independently of the reader: T = 1/n; rates q+ = q T, so a rate derivative
// is D_w = D_c c / (U T); m+ = m / (1/2 rho U S_t T); I+ = I / (1/2 rho U^2 S_t c T^2); g+ = g T / U.
struct Wingbeat {
  ReferenceQuantities ref;  // U, c, S_t, rho, frequency as the file gives them
  double m = 0, Ixx = 0, Iyy = 0, Izz = 0, Ixz = 0, g = 0;  // m+, I+, g+ (wingbeat)
  Eigen::Matrix<double, 6, 6> D;                             // derivatives, rates per q T
};

Wingbeat to_wingbeat(const DerivativeTable& t) {
  const auto& r = t.reference;
  const double T = 1.0 / r.frequency;
  const double mass_scale = 0.5 * r.rho * r.U * r.S_t * T;
  const double inertia_scale = 0.5 * r.rho * r.U * r.U * r.S_t * r.c * T * T;
  Wingbeat w;
  w.ref = r;
  w.m = t.mass.m / mass_scale;
  w.Ixx = t.mass.Ixx / inertia_scale;
  w.Iyy = t.mass.Iyy / inertia_scale;
  w.Izz = t.mass.Izz / inertia_scale;
  w.Ixz = t.mass.Ixz / inertia_scale;
  w.g = r.g * T / r.U;
  w.D = t.nd;
  for (int row = 0; row < 6; ++row)
    for (int col = 3; col < 6; ++col) w.D(row, col) = t.nd(row, col) * r.c / (r.U * T);  // columns p, q, r
  return w;
}

std::string toml_text(const Wingbeat& w, bool lateral, bool coupling) {
  std::string s = "source = \"the bumblebee table in the wingbeat convention\"\n\n[reference]\ntime = \"wingbeat\"\n";
  s += "U = " + num(w.ref.U) + "\nc = " + num(w.ref.c) + "\nS_t = " + num(w.ref.S_t) + "\nrho = " + num(w.ref.rho) +
       "\nfrequency = " + num(w.ref.frequency) + "\n\n[mass]\nm_plus = " + num(w.m) + "\nIyy_plus = " + num(w.Iyy) + "\n";
  if (lateral || coupling)
    s += "Ixx_plus = " + num(w.Ixx) + "\nIzz_plus = " + num(w.Izz) + "\nIxz_plus = " + num(w.Ixz) + "\n";
  s += "g_plus = " + num(w.g) + "\n";
  auto section = [&](const char* name, const std::vector<std::string>& names) {
    s += std::string("\n[derivatives.") + name + "]\n";
    for (const auto& n : names)
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c)
          if (derivative_name(r, c) == n) s += n + " = " + num(w.D(r, c)) + "\n";
  };
  section("longitudinal", longitudinal_derivative_names());
  if (lateral) section("lateral", lateral_derivative_names());
  if (coupling) section("coupling", coupling_derivative_names());
  return s;
}

std::vector<std::complex<double>> eigenvalues(const Eigen::MatrixXd& A, double scale) {
  Eigen::EigenSolver<Eigen::MatrixXd> es(A, false);
  std::vector<std::complex<double>> v;
  for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) v.push_back(es.eigenvalues()(i) * scale);
  return v;
}

// Dimensional eigenvalues (1/s) of a system built from a table: lambda = lambda+ U / c.
std::vector<std::complex<double>> per_second(const StateSpace& s, const DerivativeTable& t) {
  return eigenvalues(s.A, 1.0 / t.reference.time_scale());
}

class TableConventions : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("flapstab_conv_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    chord_ = read_derivative_table(write(kBumblebee, "chord.toml"));
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& text, const std::string& name) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  fs::path dir_;
  DerivativeTable chord_;
};

}  // namespace

// The bumblebee in both conventions: the same dimensional eigenvalues, longitudinal, lateral and 6DoF.
TEST_F(TableConventions, SameSystemSameDimensionalEigenvalues) {
  ASSERT_TRUE(chord_.has_longitudinal && chord_.has_lateral);
  const Wingbeat w = to_wingbeat(chord_);
  const DerivativeTable wb = read_derivative_table(write(toml_text(w, true, true), "wingbeat.toml"));
  const auto lon_c = per_second(longitudinal_system(chord_), chord_);
  const auto lon_w = per_second(longitudinal_system(wb), wb);
  EXPECT_LT(max_relative_mismatch(lon_w, lon_c), 1e-10);
  EXPECT_LT(max_relative_mismatch(per_second(lateral_system(wb), wb), per_second(lateral_system(chord_), chord_)), 1e-10);
  EXPECT_LT(max_relative_mismatch(per_second(coupled_system(wb), wb), per_second(coupled_system(chord_), chord_)), 1e-10);
  // The numbers of the two files do differ: the rate derivatives by k = c n / U, m+ by k, Iy+ by k^2.
  const double k = chord_.reference.c * chord_.reference.frequency / chord_.reference.U;
  EXPECT_NEAR(w.D(4, 4) / chord_.at("Mq"), k, 1e-12 * k);
  EXPECT_NEAR(nondimensional_parameters(chord_).Iyy / w.Iyy, 1 / (k * k), 1e-12 / (k * k));
  // The same unstable root in the analysis, per second and per wingbeat.
  const auto a = analyse_stability(chord_), b = analyse_stability(wb);
  ASSERT_TRUE(a.longitudinal && b.longitudinal);
  const Mode& ma = a.longitudinal->modes.front();
  const Mode& mb = b.longitudinal->modes.front();
  EXPECT_EQ(ma.label, mb.label);
  EXPECT_LT(std::abs(mb.eigenvalue_per_s - ma.eigenvalue_per_s), 1e-10 * std::abs(ma.eigenvalue_per_s));
  EXPECT_LT(std::abs(mb.eigenvalue_per_wingbeat - ma.eigenvalue_per_wingbeat),
            1e-10 * std::abs(ma.eigenvalue_per_wingbeat));
}

// A wingbeat table typed in as a paper prints it: its eigenvalues per wingbeat are those of the paper's matrix
// A_w = [[Xu/m+, Xw/m+, Xq/m+, -g+], [Zu/m+, Zw/m+, Zq/m+, 0], [Mu/Iy+, Mw/Iy+, Mq/Iy+, 0], [0, 0, 1, 0]] built
// from the printed numbers (Sun & Xiong 2005), and lambda = lambda+ n per second; rho, S_t, U and c then change
// nothing in them.
TEST_F(TableConventions, PrintedWingbeatTableGivesItsOwnMatrixEigenvalues) {
  const Wingbeat w = to_wingbeat(chord_);
  const auto& D = w.D;
  Eigen::MatrixXd Aw(4, 4);
  Aw << D(0, 0) / w.m, D(0, 2) / w.m, D(0, 4) / w.m, -w.g,  //
      D(2, 0) / w.m, D(2, 2) / w.m, D(2, 4) / w.m, 0,        //
      D(4, 0) / w.Iyy, D(4, 2) / w.Iyy, D(4, 4) / w.Iyy, 0,  //
      0, 0, 1, 0;
  const auto per_wingbeat = eigenvalues(Aw, 1.0);
  const auto expected_per_s = eigenvalues(Aw, w.ref.frequency);
  Wingbeat other = w;
  other.ref.rho = 1.0;
  other.ref.S_t = 3 * w.ref.S_t;
  other.ref.U = 0.7 * w.ref.U;
  other.ref.c = 1.3 * w.ref.c;
  for (const Wingbeat& v : {w, other}) {
    const DerivativeTable t = read_derivative_table(write(toml_text(v, false, false), "printed.toml"));
    EXPECT_LT(max_relative_mismatch(per_second(longitudinal_system(t), t), expected_per_s), 1e-10);
    const auto rep = analyse_stability(t);
    ASSERT_TRUE(rep.longitudinal);
    for (const Mode& m : rep.longitudinal->modes) {
      double best = 1e300;
      for (const auto& l : per_wingbeat) best = std::min(best, std::abs(m.eigenvalue_per_wingbeat - l) / std::abs(l));
      EXPECT_LT(best, 1e-10) << m.label;
    }
  }
}
