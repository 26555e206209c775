// Insect morphology: planform integrals and rigid-body mass properties.
#include "core/insect.hpp"
#include "core/quadrature.hpp"
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace flapstab {

Mat3 Body::ellipsoid_inertia() const {
  const double a = length / 2, b = width / 2, c = height / 2;
  return Eigen::Vector3d(mass * (b * b + c * c) / 5, mass * (a * a + c * c) / 5, mass * (a * a + b * b) / 5)
      .asDiagonal();
}

double Wing::chord(double r) const {
  const double x = r / length;
  if (x < 0 || x > 1) return 0;
  switch (planform) {
    case Planform::elliptic:  // Berman & Wang 2007: c(r) = (4 c_bar / pi) sqrt(1 - (r/R)^2)
      return 4 * mean_chord / pi * std::sqrt(std::max(0.0, 1 - x * x));
    case Planform::rectangular:
      return mean_chord;
    case Planform::polynomial: {
      double c = 0;
      for (auto k = poly.rbegin(); k != poly.rend(); ++k) c = c * x + *k;  // Horner
      return mean_chord * c;
    }
    case Planform::tabulated: {
      auto it = std::upper_bound(table_r.begin(), table_r.end(), x);
      if (it == table_r.begin()) return table_c.front() * mean_chord;
      if (it == table_r.end()) return table_c.back() * mean_chord;
      const std::size_t i = std::size_t(it - table_r.begin());
      const double s = (x - table_r[i - 1]) / (table_r[i] - table_r[i - 1]);
      return mean_chord * ((1 - s) * table_c[i - 1] + s * table_c[i]);
    }
  }
  throw std::logic_error("unknown planform");
}

namespace {
// Gauss-Legendre rule of n points, computed once per n.
struct Gauss {
  std::vector<double> x, w;
  explicit Gauss(int n) { gauss_legendre(n, x, w); }
};

// Integral over the span of f(r, c(r)) dr. Analytic planforms (elliptic, rectangular, polynomial): r = R sin(t),
// which removes the square-root tip of the ellipse, then 64-point Gauss-Legendre in t (the integrands are smooth
// in t, so the rule converges to round-off for the polynomial moments used here). Tabulated: 4-point Gauss on each linear segment (exact for r^k c^m,
// k + m <= 7).
template <class F>
double span_integral(const Wing& w, F f) {
  double s = 0;
  if (w.planform == Planform::tabulated) {
    static const Gauss g(4);
    for (std::size_t i = 1; i < w.table_r.size(); ++i) {
      const double a = w.table_r[i - 1] * w.length, b = w.table_r[i] * w.length;
      for (std::size_t k = 0; k < g.x.size(); ++k) {
        const double r = 0.5 * (a + b) + 0.5 * (b - a) * g.x[k];
        s += 0.5 * (b - a) * g.w[k] * f(r, w.chord(r));
      }
    }
    return s;
  }
  static const Gauss g(64);
  for (std::size_t k = 0; k < g.x.size(); ++k) {
    const double t = pi / 4 * (1 + g.x[k]);  // [0, pi/2]
    const double r = w.length * std::sin(t);
    s += pi / 4 * g.w[k] * f(r, w.chord(r)) * w.length * std::cos(t);
  }
  return s;
}
}  // namespace

double Wing::radius_of_moment(int k) const {
  const double m = span_integral(*this, [k](double r, double c) { return std::pow(r, k) * c; });
  const double s = span_integral(*this, [](double, double c) { return c; });
  return std::pow(m / s, 1.0 / k);
}

void Wing::plate_mass_properties(Vec3& centre, Mat3& inertia_hinge) const {
  // Chord segment at span r runs from x = -(1-x0) c (trailing edge) to x = x0 c (leading edge).
  const double area_num = span_integral(*this, [](double, double c) { return c; });
  const double sigma = mass / area_num;
  const double x0 = pitch_axis;
  auto xm = [x0](double c) { return (x0 - 0.5) * c; };                                   // segment centroid
  auto x2 = [x0](double c) { return c * c * (x0 * x0 * x0 + std::pow(1 - x0, 3)) / 3; };  // segment mean of x^2
  const double Sx = sigma * span_integral(*this, [&](double, double c) { return c * xm(c); });
  const double Sy = sigma * span_integral(*this, [](double r, double c) { return c * r; });
  const double Sxx = sigma * span_integral(*this, [&](double, double c) { return c * x2(c); });
  const double Syy = sigma * span_integral(*this, [](double r, double c) { return c * r * r; });
  const double Sxy = sigma * span_integral(*this, [&](double r, double c) { return c * xm(c) * r; });
  centre = Vec3(Sx / mass, Sy / mass, 0);
  inertia_hinge << Syy, -Sxy, 0, -Sxy, Sxx, 0, 0, 0, Sxx + Syy;
}

}  // namespace flapstab
