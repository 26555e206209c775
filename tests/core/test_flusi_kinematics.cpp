// Tests for core/flusi_kinematics: FLUSI .ini series, units, conventions, the angle map and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "core/errors.hpp"
#include "core/flusi_kinematics.hpp"
#include "core/rotation.hpp"
#include "core/types.hpp"

namespace flapstab {
namespace {

namespace fs = std::filesystem;

const std::string data_dir = std::string(FLAPSTAB_SOURCE_DIR) + "/data/kinematics/";

class FlusiKinematics : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("flapstab_flusi_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }

  fs::path dir_;
};

// u(t) = a0/2 + sum_i ai cos(2 pi i t) + bi sin(2 pi i t): FLUSI's fseries_eval formula.
double flusi_fourier(double a0, const std::vector<double>& a, const std::vector<double>& b, double t) {
  double u = a0 / 2;
  for (std::size_t i = 0; i < a.size(); ++i) {
    u += a[i] * std::cos(2 * pi * double(i + 1) * t) + b[i] * std::sin(2 * pi * double(i + 1) * t);
  }
  return u;
}

std::string join(const std::vector<double>& v) {
  std::ostringstream s;
  s.precision(17);
  for (std::size_t i = 0; i < v.size(); ++i) s << (i ? " " : "") << v[i];
  return s.str();
}

TEST_F(FlusiKinematics, FourierFileReproducesSeriesWithHalfA0AndDegrees) {
  // Fortran exponents and repeat counts, commas, FLUSI-style trailing comments, mixed-case keywords.
  const std::string path = write("fourier.ini",
                                 "; test file\n[kinematics]\nformat=2015-10-09; currently unused\n"
                                 "type=Fourier;\nunits=DEGREE;\nconvention=FluSI;\n"
                                 "nfft_phi=3;\na0_phi=2.0d1;\nai_phi=6.0d1 1.5D0 -2.5d-1;\nbi_phi=5.0d0, -1.0d0, 3e-1;\n"
                                 "nfft_alpha=2;\na0_alpha=-6.0d-1;\nai_alpha=3.3 0.6;\nbi_alpha=67.5 +0.7;\n"
                                 "nfft_theta=2;\na0_theta=-17.8;\nai_theta=2*-4.0;\nbi_theta=-2.3 0;\n");
  const WingAngles w = read_flusi_kinematics(path);
  ASSERT_TRUE(w.stroke.is_fourier());
  // The mean is a0/2, mapped: phi = -phi_F, alpha = 90 deg - alpha_F, theta = -theta_F.
  EXPECT_NEAR(w.stroke.fourier()->mean, -10.0 * deg, 1e-15);
  EXPECT_NEAR(w.pitch.fourier()->mean, (90.0 + 0.3) * deg, 1e-15);
  EXPECT_NEAR(w.deviation.fourier()->mean, 8.9 * deg, 1e-15);
  for (int i = 0; i <= 200; ++i) {
    const double t = i / 200.0;
    EXPECT_NEAR(w.stroke.eval(t).f, -deg * flusi_fourier(20, {60, 1.5, -0.25}, {5, -1, 0.3}, t), 1e-12);
    EXPECT_NEAR(w.pitch.eval(t).f, pi / 2 - deg * flusi_fourier(-0.6, {3.3, 0.6}, {67.5, 0.7}, t), 1e-12);
    EXPECT_NEAR(w.deviation.eval(t).f, -deg * flusi_fourier(-17.8, {-4.0, -4.0}, {-2.3, 0}, t), 1e-12);
  }
}

TEST_F(FlusiKinematics, FourierWithoutModesIsConstant) {
  const std::string path = write("constant.ini",
                                 "[kinematics]\ntype=fourier;\nnfft_phi=0;\na0_phi=30;\nnfft_alpha=0;\na0_alpha=0;\n"
                                 "nfft_theta=0;\na0_theta=0;\n");
  const WingAngles w = read_flusi_kinematics(path);
  EXPECT_NEAR(w.stroke.eval(0.3).f, -15 * deg, 1e-15);
  EXPECT_NEAR(w.pitch.eval(0.7).f, pi / 2, 1e-15);
  EXPECT_NEAR(w.deviation.peak_to_peak(), 0.0, 1e-15);
}

TEST_F(FlusiKinematics, HermiteFileReproducesNodeValuesAndSlopes) {
  // data/kinematics/harmonic_hermite16.ini: phi_F = 70 cos(2 pi t), alpha_F = 55 sin(2 pi t), theta_F = 0.
  const WingAngles w = read_flusi_kinematics(data_dir + "harmonic_hermite16.ini");
  ASSERT_NE(w.stroke.hermite(), nullptr);
  ASSERT_EQ(w.stroke.hermite()->values.size(), 16u);
  for (int j = 0; j < 16; ++j) {
    const double t = j / 16.0, c = std::cos(2 * pi * t), s = std::sin(2 * pi * t);
    const SeriesValue phi = w.stroke.eval(t), alpha = w.pitch.eval(t), theta = w.deviation.eval(t);
    EXPECT_NEAR(phi.f, -70 * deg * c, 1e-14);
    EXPECT_NEAR(phi.df, 70 * deg * 2 * pi * s, 1e-13);
    EXPECT_NEAR(alpha.f, pi / 2 - 55 * deg * s, 1e-14);
    EXPECT_NEAR(alpha.df, -55 * deg * 2 * pi * c, 1e-13);
    EXPECT_EQ(theta.f, 0.0);
    EXPECT_EQ(theta.df, 0.0);
  }
}

TEST_F(FlusiKinematics, HermiteInterpolationErrorIsFourthOrder) {
  // f(t) = 1.2 cos(2 pi t) + 0.3 sin(4 pi t) (rad) at N nodes with exact slopes; the cubic Hermite error
  // is bounded by h^4/384 max|f''''| and falls 16-fold when N doubles.
  auto f = [](double t) { return 1.2 * std::cos(2 * pi * t) + 0.3 * std::sin(4 * pi * t); };
  auto df = [](double t) { return -1.2 * 2 * pi * std::sin(2 * pi * t) + 0.3 * 4 * pi * std::cos(4 * pi * t); };
  auto max_error = [&](int n) {
    std::vector<double> v, d;
    for (int j = 0; j < n; ++j) {
      v.push_back(-f(double(j) / n));  // FLUSI phi = -flapstab phi
      d.push_back(-df(double(j) / n));
    }
    const std::string path = write("h" + std::to_string(n) + ".ini",
                                   "[kinematics]\ntype=hermite;\nunits=radiant;\nnfft_phi=" + std::to_string(n) +
                                       ";\nai_phi=" + join(v) + ";\nbi_phi=" + join(d) +
                                       ";\nnfft_alpha=1;\nai_alpha=0;\nbi_alpha=0;\nnfft_theta=1;\nai_theta=0;\nbi_theta=0;\n");
    const WingAngles w = read_flusi_kinematics(path);
    double e = 0;
    for (int i = 0; i < 4000; ++i) e = std::max(e, std::abs(w.stroke.eval(i / 4000.0).f - f(i / 4000.0)));
    return e;
  };
  const double e16 = max_error(16), e32 = max_error(32);
  const double f4 = 1.2 * std::pow(2 * pi, 4) + 0.3 * std::pow(4 * pi, 4);
  EXPECT_LE(e16, f4 * std::pow(1.0 / 16, 4) / 384);
  EXPECT_LE(e32, f4 * std::pow(1.0 / 32, 4) / 384);
  EXPECT_NEAR(e16 / e32, 16.0, 2.0);
}

TEST_F(FlusiKinematics, RadiantUnitsAreTakenAsGiven) {
  const std::string body = "nfft_phi=1;\na0_phi=0.2;\nai_phi=1.0;\nbi_phi=0.5;\nnfft_alpha=1;\na0_alpha=1.0;\n"
                           "ai_alpha=0;\nbi_alpha=0.8;\nnfft_theta=1;\na0_theta=0;\nai_theta=0.1;\nbi_theta=0;\n";
  const WingAngles r = read_flusi_kinematics(write("rad.ini", "[kinematics]\ntype=fourier;\nunits=Radiant;\n" + body));
  const WingAngles d = read_flusi_kinematics(write("deg.ini", "[kinematics]\ntype=fourier;\n" + body));
  for (double t : {0.0, 0.1, 0.37, 0.8}) {
    EXPECT_NEAR(r.stroke.eval(t).f, -(0.1 + std::cos(2 * pi * t) + 0.5 * std::sin(2 * pi * t)), 1e-14);
    EXPECT_NEAR(r.pitch.eval(t).f, pi / 2 - (0.5 + 0.8 * std::sin(2 * pi * t)), 1e-14);
    EXPECT_NEAR(d.stroke.eval(t).f, deg * r.stroke.eval(t).f, 1e-14);  // default units: degree
    EXPECT_NEAR(d.deviation.eval(t).f, deg * r.deviation.eval(t).f, 1e-14);
  }
}

TEST_F(FlusiKinematics, SiscConventionFlipsOnlyTheDeviation) {
  const std::string body = "type=fourier;\nnfft_phi=1;\na0_phi=10;\nai_phi=70;\nbi_phi=3;\nnfft_alpha=1;\na0_alpha=2;\n"
                           "ai_alpha=4;\nbi_alpha=60;\nnfft_theta=2;\na0_theta=-17.8;\nai_theta=-4 -8.3;\nbi_theta=-2.3 1;\n";
  const WingAngles f = read_flusi_kinematics(write("flusi.ini", "[kinematics]\nconvention=flusi;\n" + body));
  const WingAngles s = read_flusi_kinematics(write("sisc.ini", "[kinematics]\nconvention=SISC;\n" + body));
  for (double t : {0.0, 0.21, 0.5, 0.93}) {
    const double theta_file = deg * flusi_fourier(-17.8, {-4, -8.3}, {-2.3, 1}, t);
    EXPECT_NEAR(f.deviation.eval(t).f, -theta_file, 1e-14);  // FLUSI: positive theta is ventral
    EXPECT_NEAR(s.deviation.eval(t).f, theta_file, 1e-14);   // SISC: positive theta is dorsal, as flapstab
    EXPECT_EQ(s.stroke.eval(t).f, f.stroke.eval(t).f);
    EXPECT_EQ(s.pitch.eval(t).f, f.pitch.eval(t).f);
  }
}

// FLUSI's frame-change matrices (src/insects/rotation_matrices.f90): passive, x' = R x.
Mat3 flusi_rx(double a) { return rot_x(a).transpose(); }
Mat3 flusi_ry(double a) { return rot_y(a).transpose(); }
Mat3 flusi_rz(double a) { return rot_z(a).transpose(); }

TEST_F(FlusiKinematics, AngleMapReproducesFlusiWingOrientation) {
  // FLUSI body axes: x to the head, y left, z dorsal; x_wing = M_wing x_body with
  //   right: M = Ry(-alpha) Rz(theta) Rx(-phi) Rx(pi) Ry(eta),  left: M = Ry(alpha) Rz(theta) Rx(phi) Ry(eta),
  // wing x = towards the leading edge, y = span. The reader's map, with flapstab's stroke plane
  // beta = chi - eta - 90 deg, must give the same chord and span directions in stability axes.
  const double phi_f = 0.7, alpha_f = 0.95, theta_f = -0.2;  // FLUSI angles, rad
  const WingAngles w = read_flusi_kinematics(
      write("pose.ini", "[kinematics]\ntype=fourier;\nunits=radiant;\nnfft_phi=0;\na0_phi=" + join({2 * phi_f}) +
                            ";\nnfft_alpha=0;\na0_alpha=" + join({2 * alpha_f}) + ";\nnfft_theta=0;\na0_theta=" +
                            join({2 * theta_f}) + ";\n"));
  const double phi = w.stroke.eval(0).f, theta = w.deviation.eval(0).f, alpha = w.pitch.eval(0).f;
  const Mat3 flusi_body_to_anatomical = Vec3(1, -1, -1).asDiagonal();  // y left -> right, z dorsal -> ventral
  for (double chi : {45 * deg, 30 * deg}) {
    for (double eta : {-45 * deg, -20 * deg, 0.0, 15 * deg}) {
      const Mat3 to_s = rot_y(chi) * flusi_body_to_anatomical;
      const Mat3 m_right = flusi_ry(-alpha_f) * flusi_rz(theta_f) * flusi_rx(-phi_f) * flusi_rx(pi) * flusi_ry(eta);
      const Mat3 m_left = flusi_ry(alpha_f) * flusi_rz(theta_f) * flusi_rx(phi_f) * flusi_ry(eta);
      const double beta = chi - eta - pi / 2;
      const Mat3 right = rot_y(beta) * rot_z(-phi) * rot_x(-theta) * rot_y(alpha);  // core/configuration.hpp
      const Mat3 left = mirror_y() * right;
      for (int axis : {0, 1}) {  // chord (to the leading edge) and span
        const Vec3 e = Vec3::Unit(axis);
        EXPECT_LT((to_s * m_right.transpose() * e - right * e).norm(), 1e-14) << "right axis " << axis;
        EXPECT_LT((to_s * m_left.transpose() * e - left * e).norm(), 1e-14) << "left axis " << axis;
      }
    }
  }
}

TEST_F(FlusiKinematics, FryDrosophilaLeadsWithTheLeadingEdgeAtPlausibleIncidence) {
  // Fry et al. 2005 hovering Drosophila (FLUSI's coefficients), horizontal stroke plane. At mid
  // downstroke (phi increasing) and mid upstroke the wing must move leading edge first, with the
  // leading edge above the trailing edge, at 20-60 deg between chord and tip velocity; and the
  // flapstab reading of alpha (downstroke incidence alpha, upstroke 180 deg - alpha) must agree.
  const WingAngles w = read_flusi_kinematics(data_dir + "drosophila_fry2005_fourier.ini");
  constexpr int n = 4096;
  int i_min = 0, i_max = 0;
  for (int i = 0; i < n; ++i) {
    if (w.stroke.eval(double(i) / n).f < w.stroke.eval(double(i_min) / n).f) i_min = i;
    if (w.stroke.eval(double(i) / n).f > w.stroke.eval(double(i_max) / n).f) i_max = i;
  }
  EXPECT_LT(i_min, n / 20);  // the file starts at the rear (dorsal) reversal: downstroke first
  EXPECT_NEAR((w.stroke.eval(double(i_max) / n).f - w.stroke.eval(double(i_min) / n).f) / deg, 145, 10);
  const double t_down = 0.5 * (i_min + i_max) / n, t_up = 0.5 * (i_max + i_min + n) / n;
  auto pose = [&](double t) {
    return Mat3(rot_z(-w.stroke.eval(t).f) * rot_x(-w.deviation.eval(t).f) * rot_y(w.pitch.eval(t).f));
  };
  for (double t : {t_down, t_up}) {
    const bool down = t == t_down;
    const double h = 1e-6;
    const Vec3 chord = pose(t) * Vec3::UnitX();
    const Vec3 v = ((pose(t + h) - pose(t - h)) * Vec3::UnitY()).normalized();  // tip velocity direction
    const double incidence = std::acos(chord.dot(v)) / deg;
    EXPECT_GT(incidence, 20) << (down ? "downstroke" : "upstroke");
    EXPECT_LT(incidence, 60) << (down ? "downstroke" : "upstroke");
    EXPECT_LT(chord.z(), 0) << "leading edge must be dorsal of the trailing edge";
    EXPECT_EQ(w.stroke.eval(t).df > 0, down);
    // The deviation rate tilts the tip path out of the stroke plane, by some 6-8 deg here.
    const double alpha = w.pitch.eval(t).f / deg;
    EXPECT_NEAR(down ? alpha : 180 - alpha, incidence, 10);
  }
}

// Each malformed input: the file text and the key the error must name.
struct BadCase {
  const char* what;
  std::string text;
  std::string key;
};

std::string replaced(std::string s, const std::string& from, const std::string& to) {
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return s.replace(at, from.size(), to);
}

TEST_F(FlusiKinematics, MalformedInputsNameFileAndKey) {
  const std::string good = "[kinematics]\ntype=fourier;\nunits=degree;\nconvention=flusi;\n"
                           "nfft_phi=2;\na0_phi=0.0;\nai_phi=60.0 0.0;\nbi_phi=0.0 0.0;\n"
                           "nfft_alpha=1;\na0_alpha=0;\nai_alpha=0;\nbi_alpha=55;\n"
                           "nfft_theta=1;\na0_theta=0;\nai_theta=0;\nbi_theta=0;\n";
  const std::string hermite = "[kinematics]\ntype=hermite;\nnfft_phi=2;\nai_phi=60 -60;\nbi_phi=0 0;\n"
                              "nfft_alpha=1;\nai_alpha=0;\nbi_alpha=0;\nnfft_theta=1;\nai_theta=0;\nbi_theta=0;\n";
  EXPECT_NO_THROW(read_flusi_kinematics(write("good.ini", good)));
  EXPECT_NO_THROW(read_flusi_kinematics(write("hermite.ini", hermite)));
  const std::vector<BadCase> cases = {
      {"no section", "[insects]\nnfft_phi=2;\n", "[kinematics]"},
      {"kineloader", "0.005\n2.5\n2\n0 1 2 3 4 5 6 7 8 9 10 11 12\n0.1 1 2 3 4 5 6 7 8 9 10 11 12\n", "[kinematics]"},
      {"missing type", replaced(good, "type=fourier;\n", ""), "type"},
      {"unknown type", replaced(good, "type=fourier", "type=degree"), "type"},
      {"unknown units", replaced(good, "units=degree", "units=radian"), "units"},
      {"unknown convention", replaced(good, "convention=flusi", "convention=nasa"), "convention"},
      {"too few ai", replaced(good, "ai_phi=60.0 0.0", "ai_phi=60.0"), "ai_phi"},
      {"too many bi", replaced(good, "bi_phi=0.0 0.0", "bi_phi=0 0 0"), "bi_phi"},
      {"non-numeric", replaced(good, "bi_phi=0.0 0.0", "bi_phi=phi0 0"), "bi_phi"},
      {"NaN", replaced(good, "ai_alpha=0", "ai_alpha=NaN"), "ai_alpha"},
      {"inf", replaced(good, "a0_theta=0", "a0_theta=-inf"), "a0_theta"},
      {"overflow", replaced(good, "bi_alpha=55", "bi_alpha=1d400"), "bi_alpha"},
      {"bad repeat count", replaced(good, "bi_phi=0.0 0.0", "bi_phi=0*1 0 0"), "bi_phi"},
      {"missing nfft", replaced(good, "nfft_theta=1;\n", ""), "nfft_theta"},
      {"non-integer nfft", replaced(good, "nfft_phi=2", "nfft_phi=2.0"), "nfft_phi"},
      {"missing a0", replaced(good, "a0_phi=0.0;\n", ""), "a0_phi"},
      {"missing ai", replaced(good, "ai_alpha=0;\n", ""), "ai_alpha"},
      {"hermite without nodes", replaced(hermite, "nfft_theta=1;\nai_theta=0;\nbi_theta=0;", "nfft_theta=0;"),
       "nfft_theta"},
      {"misspelt key", replaced(good, "ai_alpha=", "ai_alpah="), "ai_alpah"},
      {"repeated key", good + "nfft_phi=2;\n", "nfft_phi"},
      {"wrapped line", replaced(good, "ai_phi=60.0 0.0;", "ai_phi=60.0\n0.0;"), "[kinematics]"},
  };
  for (const BadCase& c : cases) {
    const std::string path = write("bad.ini", c.text);
    try {
      read_flusi_kinematics(path);
      ADD_FAILURE() << c.what << ": no error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path) << c.what;
      EXPECT_EQ(e.key(), c.key) << c.what << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << c.what;
      EXPECT_NE(std::string(e.what()).find("key '" + c.key + "'"), std::string::npos) << c.what;
    }
  }
  try {
    read_flusi_kinematics(write("k.ini", cases[1].text));
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("kinematics_loader"), std::string::npos) << e.what();
  }
  const std::string missing = (dir_ / "absent.ini").string();
  try {
    read_flusi_kinematics(missing);
    ADD_FAILURE() << "missing file: no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos);
  }
}

}  // namespace
}  // namespace flapstab
