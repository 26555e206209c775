// Tests for core/series: Fourier and periodic Hermite evaluation, means, shifts and scaling.
#include <gtest/gtest.h>
#include <cmath>
#include <vector>
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

// Sixth-order central difference of g at tau: truncation ~ h^6 f^(7) / 140, round-off ~ 1e-16 f / h; with h = 1e-4
// both stay below 1e-10 even for the steep C = 8 pitch, whose derivatives grow like (2 pi C)^k.
template <class G>
double sixth_order_difference(G g, double tau, double h) {
  return (-g(tau - 3 * h) + 9 * g(tau - 2 * h) - 45 * g(tau - h) + 45 * g(tau + h) - 9 * g(tau + 2 * h) +
          g(tau + 3 * h)) /
         (60 * h);
}

// The Berman & Wang (2007, J Fluid Mech 582:153) forms: closed-form rates and accelerations against
// finite differences of the values (and of the rates) to 1e-8, relative to the derivative's size.
TEST(Series, BermanWangDerivativesMatchFiniteDifferences) {
  using F = BermanWangSeries::Form;
  const std::vector<BermanWangSeries> forms = {
      {F::stroke, 1.0, 0.1, 0.7, 0.3, 1},    {F::stroke, 1.2, 0.0, 0.95, -1.1, 1},
      {F::pitch, -0.9, 1.57, 2.4, 0.4, 1},   {F::pitch, 0.8, 0.0, 8.0, 0.0, 1},
      {F::deviation, 0.2, 0.05, 0, 0.7, 2},  {F::deviation, 0.1, 0.0, 0, -0.2, 3}};
  const double h = 1e-4;
  for (const auto& b : forms) {
    for (double tau : {0.0, 0.07, 0.25, 0.4, 0.5, 0.81, 0.97}) {
      const SeriesValue v = b.eval(tau);
      const double df = sixth_order_difference([&](double t) { return b.eval(t).f; }, tau, h);
      const double ddf = sixth_order_difference([&](double t) { return b.eval(t).df; }, tau, h);
      EXPECT_NEAR(v.df, df, 1e-8 * (1 + std::abs(v.df))) << int(b.form) << " tau " << tau;
      EXPECT_NEAR(v.ddf, ddf, 1e-8 * (1 + std::abs(v.ddf))) << int(b.form) << " tau " << tau;
    }
  }
}

// K -> 0: asin(K x) / asin K = x (1 + O(K^2)), the cosine; C -> 0: tanh(C x) / tanh C = x (1 + O(C^2)), the sine.
// With K = C = 1e-6 the forms must equal the limits (values and derivatives) to 1e-11.
TEST(Series, BermanWangSmallShapeGivesCosineAndSine) {
  using F = BermanWangSeries::Form;
  const BermanWangSeries stroke{F::stroke, 1.1, 0.2, 1e-6, 0.4, 1}, pitch{F::pitch, -0.9, 1.5, 1e-6, 0.3, 1};
  const double w = 2 * pi;
  for (double tau = 0; tau < 1; tau += 0.0625) {
    const double ps = w * tau + 0.4, pp = w * tau + 0.3;
    const SeriesValue s = stroke.eval(tau), p = pitch.eval(tau);
    EXPECT_NEAR(s.f, 0.2 + 1.1 * std::cos(ps), 1e-11);
    EXPECT_NEAR(s.df, -1.1 * w * std::sin(ps), 1e-11 * w);
    EXPECT_NEAR(s.ddf, -1.1 * w * w * std::cos(ps), 1e-11 * w * w);
    EXPECT_NEAR(p.f, 1.5 - 0.9 * std::sin(pp), 1e-11);
    EXPECT_NEAR(p.df, -0.9 * w * std::cos(pp), 1e-11 * w);
    EXPECT_NEAR(p.ddf, 0.9 * w * w * std::sin(pp), 1e-11 * w * w);
  }
}

// The mean is exact (each oscillation integrates to zero over a cycle), the excursion is +-amplitude, and the
// trim operations scale the amplitude and shift the mean.
TEST(Series, BermanWangMeanAmplitudeShiftScale) {
  using F = BermanWangSeries::Form;
  for (const BermanWangSeries& b : {BermanWangSeries{F::stroke, 1.0, 0.3, 0.9, 0.2, 1},
                                    BermanWangSeries{F::pitch, 0.8, 1.6, 3.0, 0.5, 1},
                                    BermanWangSeries{F::deviation, 0.1, -0.05, 0, 0.1, 2}}) {
    AngleSeries a(b);
    constexpr int n = 4096;  // trapezoid on a periodic smooth function: exponentially accurate
    double m = 0;
    for (int i = 0; i < n; ++i) m += a.eval(double(i) / n).f / n;
    EXPECT_NEAR(m, b.mean, 1e-12);
    EXPECT_DOUBLE_EQ(a.mean(), b.mean);
    EXPECT_NEAR(a.peak_to_peak(), 2 * std::abs(b.amplitude), 1e-5);  // sampled at 2048 phases
    a.scale_oscillation(0.5);
    a.shift(0.1);
    EXPECT_DOUBLE_EQ(a.berman_wang()->amplitude, 0.5 * b.amplitude);
    EXPECT_DOUBLE_EQ(a.mean(), b.mean + 0.1);
  }
}

}  // namespace
}  // namespace flapstab
