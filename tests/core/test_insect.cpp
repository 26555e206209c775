// Tests for core/insect: planform integrals (closed forms for the ellipse and the rectangle) and
// thin-plate / ellipsoid mass properties.
#include <gtest/gtest.h>
#include "core/insect.hpp"

namespace flapstab {
namespace {

Wing wing(Planform p) {
  Wing w;
  w.length = 0.05;
  w.mean_chord = 0.018;
  w.planform = p;
  w.mass = 4e-5;
  w.pitch_axis = 0.25;
  return w;
}

// Elliptic c(r) = (4 c/pi) sqrt(1 - (r/R)^2): area c R, r1 = 4R/(3 pi), r2 = R/2 (exact).
TEST(Insect, EllipticPlanformMoments) {
  const Wing w = wing(Planform::elliptic);
  EXPECT_NEAR(w.radius_of_moment(1), 4 * w.length / (3 * pi), 1e-14);
  EXPECT_NEAR(w.radius_of_moment(2), 0.5 * w.length, 1e-14);
  EXPECT_NEAR(w.chord(0.0), 4 * w.mean_chord / pi, 1e-15);
  EXPECT_EQ(w.chord(w.length * 1.01), 0.0);
}

TEST(Insect, RectangularAndTabulatedAgree) {
  const Wing r = wing(Planform::rectangular);
  EXPECT_NEAR(r.radius_of_moment(2), r.length / std::sqrt(3.0), 1e-14);
  Wing t = wing(Planform::tabulated);
  t.table_r = {0.0, 0.3, 1.0};
  t.table_c = {1.0, 1.0, 1.0};
  EXPECT_NEAR(t.radius_of_moment(2), r.radius_of_moment(2), 1e-14);
  EXPECT_NEAR(t.chord(0.4 * t.length), t.mean_chord, 1e-15);
}

// Polynomial chord c/c_bar = sum a_k (r/R)^k, normalised to unit mean: the triangle 1 - r/R becomes 2 (1 - r/R);
// int r c = R^2/6 and int r^2 c = R^3/12 over int c = R/2 give r1 = R/3 and r2 = R/sqrt(6) (exact moments).
TEST(Insect, PolynomialPlanformMoments) {
  Wing w = wing(Planform::polynomial);
  w.poly = {2.0, -2.0};
  EXPECT_NEAR(w.radius_of_moment(1), w.length / 3, 1e-14);
  EXPECT_NEAR(w.radius_of_moment(2), w.length / std::sqrt(6.0), 1e-14);
  EXPECT_NEAR(w.chord(0.25 * w.length), 1.5 * w.mean_chord, 1e-15);
  EXPECT_EQ(w.chord(w.length * 1.01), 0.0);
  w.poly = {1.0};  // the rectangle, exactly
  const Wing r = wing(Planform::rectangular);
  for (double x : {0.0, 0.3, 0.77, 1.0}) EXPECT_EQ(w.chord(x * w.length), r.chord(x * r.length));
}

// Uniform rectangular plate, pitch axis at x0 c from the LE: centroid at (x0 - 1/2) c chordwise and
// R/2 spanwise; Ixx (about the chord axis through the hinge) = m R^2 / 3; Iyy = m c^2 (x0^3 + (1-x0)^3) / 3.
TEST(Insect, PlateMassProperties) {
  const Wing w = wing(Planform::rectangular);
  Vec3 c;
  Mat3 I;
  w.plate_mass_properties(c, I);
  const double m = w.mass, R = w.length, ch = w.mean_chord, x0 = w.pitch_axis;
  EXPECT_NEAR(c.x(), (x0 - 0.5) * ch, 1e-15);
  EXPECT_NEAR(c.y(), R / 2, 1e-15);
  EXPECT_NEAR(I(0, 0), m * R * R / 3, 1e-18);
  EXPECT_NEAR(I(1, 1), m * ch * ch * (x0 * x0 * x0 + std::pow(1 - x0, 3)) / 3, 1e-20);
  EXPECT_NEAR(I(2, 2), I(0, 0) + I(1, 1), 1e-20);
  EXPECT_NEAR(I(0, 1), -m * (x0 - 0.5) * ch * R / 2, 1e-20);
}

TEST(Insect, EllipsoidInertia) {
  Body b;
  b.mass = 1e-3;
  b.length = 0.04;
  b.width = 0.01;
  b.height = 0.01;
  const Mat3 I = b.ellipsoid_inertia();
  EXPECT_NEAR(I(0, 0), 1e-3 * (0.005 * 0.005 * 2) / 5, 1e-18);
  EXPECT_NEAR(I(1, 1), 1e-3 * (0.02 * 0.02 + 0.005 * 0.005) / 5, 1e-18);
}

}  // namespace
}  // namespace flapstab
