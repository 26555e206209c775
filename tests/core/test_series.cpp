// Tests for core/series: Fourier and periodic Hermite evaluation, means, shifts and scaling.
#include <gtest/gtest.h>
#include <cmath>
#include "core/series.hpp"
#include "core/types.hpp"

namespace flapstab {
namespace {

TEST(Series, FourierDerivativesMatchCentralDifferences) {
  const FourierSeries f{0.3, {1.0, -0.2, 0.05}, {0.4, 0.1, -0.03}};
  const double h = 1e-5;
  for (double tau : {0.0, 0.13, 0.5, 0.77}) {
    const auto v = f.eval(tau), p = f.eval(tau + h), m = f.eval(tau - h);
    EXPECT_NEAR(v.df, (p.f - m.f) / (2 * h), 1e-8);
    EXPECT_NEAR(v.ddf, (p.df - m.df) / (2 * h), 1e-6);
  }
  EXPECT_DOUBLE_EQ(AngleSeries(f).mean(), 0.3);
}

TEST(Series, HermiteHitsNodesAndIsPeriodic) {
  const int n = 16;
  HermiteSeries h;
  for (int j = 0; j < n; ++j) {
    const double t = double(j) / n;
    h.values.push_back(std::sin(2 * pi * t));
    h.slopes.push_back(2 * pi * std::cos(2 * pi * t));
  }
  for (int j = 0; j < n; ++j) {
    EXPECT_NEAR(h.eval(double(j) / n).f, h.values[j], 1e-14);
    EXPECT_NEAR(h.eval(double(j) / n).df, h.slopes[j], 1e-12);
  }
  EXPECT_NEAR(h.eval(1.25).f, h.eval(0.25).f, 1e-14);
  // Cubic Hermite interpolation error <= h^4/384 max|f''''| = (1/16)^4 / 384 (2 pi)^4 ~ 6.2e-5.
  for (double t = 0; t < 1; t += 0.01) EXPECT_NEAR(h.eval(t).f, std::sin(2 * pi * t), 6.2e-5);
  EXPECT_NEAR(AngleSeries(h).mean(), 0.0, 1e-14);
}

TEST(Series, ShiftAndScaleOscillation) {
  AngleSeries a(FourierSeries{0.5, {1.0}, {0.0}});
  a.scale_oscillation(0.5);
  a.shift(0.25);
  EXPECT_NEAR(a.eval(0.0).f, 0.75 + 0.5, 1e-15);
  EXPECT_NEAR(a.mean(), 0.75, 1e-15);
  EXPECT_NEAR(a.peak_to_peak(), 1.0, 1e-12);
}

}  // namespace
}  // namespace flapstab
