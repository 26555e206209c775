// Periodic angle histories: Fourier and periodic cubic Hermite evaluation.
#include "core/series.hpp"
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include "core/types.hpp"

namespace flapstab {

SeriesValue FourierSeries::eval(double tau) const {
  SeriesValue v{mean + rate * tau, rate, 0};
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double w = 2 * pi * double(i + 1);
    const double c = std::cos(w * tau), s = std::sin(w * tau);
    v.f += a[i] * c + b[i] * s;
    v.df += w * (-a[i] * s + b[i] * c);
    v.ddf += -w * w * (a[i] * c + b[i] * s);
  }
  return v;
}

SeriesValue HermiteSeries::eval(double tau) const {
  const std::size_t n = values.size();
  const double h = 1.0 / double(n);
  double t = tau - std::floor(tau);
  std::size_t j = std::min(std::size_t(t / h), n - 1);
  const std::size_t k = (j + 1) % n;
  const double s = (t - double(j) * h) / h;  // local coordinate in [0,1)
  const double p0 = values[j], p1 = values[k], m0 = slopes[j] * h, m1 = slopes[k] * h;
  const double s2 = s * s, s3 = s2 * s;
  SeriesValue v;
  v.f = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1;
  v.df = ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * p1 + (3 * s2 - 2 * s) * m1) / h;
  v.ddf = ((12 * s - 6) * p0 + (6 * s - 4) * m0 + (-12 * s + 6) * p1 + (6 * s - 2) * m1) / (h * h);
  return v;
}

SeriesValue BermanWangSeries::eval(double tau) const {
  const double w = 2 * pi, psi = w * tau + phase;
  SeriesValue v{mean, 0, 0};
  if (form == Form::deviation) {
    const double n = double(harmonic), c = std::cos(n * psi), s = std::sin(n * psi);
    v.f += amplitude * c;
    v.df = -amplitude * n * w * s;
    v.ddf = -amplitude * n * n * w * w * c;
    return v;
  }
  // g(u(psi)) with u = K cos psi, g = asin (stroke) or u = C sin psi, g = tanh (pitch):
  // d/dpsi g = g'(u) u', d2/dpsi2 g = g''(u) u'^2 + g'(u) u''.
  const double c = std::cos(psi), s = std::sin(psi);
  double g, g1, g2, u1, u2, norm;
  if (form == Form::stroke) {
    const double u = shape * c, q = 1 - u * u;
    u1 = -shape * s;
    u2 = -shape * c;
    g = std::asin(u);
    g1 = 1 / std::sqrt(q);
    g2 = u / (q * std::sqrt(q));
    norm = std::asin(shape);
  } else {
    const double u = shape * s;
    u1 = shape * c;
    u2 = -shape * s;
    g = std::tanh(u);
    g1 = 1 - g * g;
    g2 = -2 * g * g1;
    norm = std::tanh(shape);
  }
  const double k = amplitude / norm;
  v.f += k * g;
  v.df = k * w * g1 * u1;
  v.ddf = k * w * w * (g2 * u1 * u1 + g1 * u2);
  return v;
}

SeriesValue AngleSeries::eval(double tau) const {
  return std::visit([tau](const auto& s) { return s.eval(tau); }, s_);
}

double AngleSeries::mean() const {
  if (auto f = fourier()) return f->mean;
  // Each Berman-Wang oscillation is odd about a quarter period (asin(K cos), tanh(C sin)) or a cosine: zero mean.
  if (auto b = berman_wang()) return b->mean;
  // Exact integral of each Hermite cubic: h (p0 + p1)/2 + h^2 (m0 - m1)/12, summed (slope terms cancel).
  const auto& h = *hermite();
  double s = 0;
  for (double v : h.values) s += v;
  return s / double(h.values.size());
}

double AngleSeries::peak_to_peak() const {
  if (revolving()) throw std::logic_error("peak-to-peak amplitude of a revolving angle");
  constexpr int n = 2048;
  double lo = 1e300, hi = -1e300;
  for (int i = 0; i < n; ++i) {
    const double f = eval(double(i) / n).f;
    lo = std::min(lo, f);
    hi = std::max(hi, f);
  }
  return hi - lo;
}

void AngleSeries::shift(double d) {
  if (auto f = std::get_if<FourierSeries>(&s_)) {
    f->mean += d;
  } else if (auto b = berman_wang()) {
    b->mean += d;
  } else {
    for (double& v : std::get<HermiteSeries>(s_).values) v += d;
  }
}

void AngleSeries::scale_oscillation(double s) {
  if (auto f = std::get_if<FourierSeries>(&s_)) {
    for (double& x : f->a) x *= s;
    for (double& x : f->b) x *= s;
  } else if (auto b = berman_wang()) {
    b->amplitude *= s;
  } else {
    auto& h = std::get<HermiteSeries>(s_);
    const double m = mean();
    for (double& v : h.values) v = m + s * (v - m);
    for (double& v : h.slopes) v *= s;
  }
}

}  // namespace flapstab
