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

// The closed forms of Berman & Wang (2007, J Fluid Mech 582:153), psi = 2 pi tau + phase:
//  stroke:    amplitude asin(K cos psi) / asin K + mean        (0 < K < 1; K -> 0: a cosine, K -> 1: a triangle wave)
//  pitch:     amplitude tanh(C sin psi) / tanh C + mean        (C > 0;     C -> 0: a sine,   C -> inf: a square wave)
//  deviation: amplitude cos(N psi) + mean                      (N >= 1 the harmonic; N = 2 traces a figure of eight)
// Berman & Wang write the stroke with sin(2 pi f t) (phase = -pi/2 here) and the deviation as
// theta_m cos(2 pi N f t + Phi_theta) + theta_0 (phase = Phi_theta / N here, so that `phase` is a time shift in
// every form). Value and derivatives are exact (closed-form chain rule), not differenced.
struct BermanWangSeries {
  enum class Form { stroke, pitch, deviation };
  Form form = Form::stroke;
  double amplitude = 0;  // phi_m, theta_m, Theta_m (rad): half the peak-to-peak excursion
  double mean = 0;       // phi_0, theta_0, Theta_0 (rad): the cycle mean (each form's oscillation has zero mean)
  double shape = 0.5;    // K (stroke) or C (pitch); unused for the deviation
  double phase = 0;      // rad of the wingbeat (a time shift of phase / 2 pi cycles)
  int harmonic = 1;      // N (deviation only)
  SeriesValue eval(double tau) const;
};

// One angle's history (radians, phase in cycles).
class AngleSeries {
 public:
  AngleSeries() : s_(FourierSeries{}) {}
  AngleSeries(FourierSeries f) : s_(std::move(f)) {}
  AngleSeries(HermiteSeries h) : s_(std::move(h)) {}
  AngleSeries(BermanWangSeries b) : s_(std::move(b)) {}
  SeriesValue eval(double tau) const;
  // Cycle mean (exact for Fourier and Berman-Wang, trapezoid over the Hermite cubic for Hermite).
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
  const BermanWangSeries* berman_wang() const { return std::get_if<BermanWangSeries>(&s_); }
  BermanWangSeries* berman_wang() { return std::get_if<BermanWangSeries>(&s_); }

 private:
  std::variant<FourierSeries, HermiteSeries, BermanWangSeries> s_;
};

}  // namespace flapstab
