// Periodic angle histories over one wingbeat: Fourier series or periodic cubic Hermite nodes.
#pragma once
#include <string>
#include <variant>
#include <vector>

namespace flapstab {

// Value and derivatives with respect to the wingbeat phase tau (cycles, period 1).
struct SeriesValue {
  double f = 0, df = 0, ddf = 0;
};

// f(tau) = mean + rate tau + sum_k a[k-1] cos(2 pi k tau) + b[k-1] sin(2 pi k tau).
// Note: `mean` is the mean itself (FLUSI files store a0 = 2 x mean; the reader converts).
// `rate` (per cycle) is zero for flapping; a revolving wing sweeps rate = 2 pi per cycle.
struct FourierSeries {
  double mean = 0;
  std::vector<double> a, b;  // same length
  double rate = 0;
  SeriesValue eval(double tau) const;
};

// Periodic cubic Hermite interpolation through N nodes at tau_j = j / N (j = 0..N-1),
// with values[j] and slopes[j] = df/dtau at the nodes (FLUSI's "hermite" type).
struct HermiteSeries {
  std::vector<double> values, slopes;
  SeriesValue eval(double tau) const;
};

// One angle's history (radians, phase in cycles).
class AngleSeries {
 public:
  AngleSeries() : s_(FourierSeries{}) {}
  AngleSeries(FourierSeries f) : s_(std::move(f)) {}
  AngleSeries(HermiteSeries h) : s_(std::move(h)) {}
  SeriesValue eval(double tau) const;
  // Cycle mean (exact for Fourier, trapezoid over the Hermite cubic for Hermite).
  double mean() const;
  // max - min over the cycle (sampled densely).
  double peak_to_peak() const;
  // Adds d to the value everywhere (shifts the mean).
  void shift(double d);
  // Scales the oscillating part about the mean by s.
  void scale_oscillation(double s);
  bool is_fourier() const { return std::holds_alternative<FourierSeries>(s_); }
  // True for a secular (revolving) angle: a Fourier series with a non-zero rate.
  bool revolving() const { return fourier() && fourier()->rate != 0; }
  const FourierSeries* fourier() const { return std::get_if<FourierSeries>(&s_); }
  const HermiteSeries* hermite() const { return std::get_if<HermiteSeries>(&s_); }

 private:
  std::variant<FourierSeries, HermiteSeries> s_;
};

}  // namespace flapstab
