// Shared fixtures for the stability tests: tables, and an eigenvalue computation independent of Eigen.
#pragma once
#include <algorithm>
#include <cmath>
#include <complex>
#include <random>
#include <vector>
#include <Eigen/Dense>
#include "core/derivative_table.hpp"

namespace flapstab::test {

// A SYNTHETIC hover-like table, not a published one: round numbers with the sign pattern that
// Sun's group's sign pattern (e.g. Sun & Xiong 2005, J Exp Biol 208:447) (X_u < 0, M_u > 0 large, Z_w < 0, M_q < 0; X_w, Z_u, Z_q
// small) and bumblebee-sized references (c = 4 mm, U = 4.5 m/s, 155 Hz), giving m+ ~ 700,
// Iy+ ~ 1000, g+ ~ 0.002.
inline DerivativeTable hover_like_table() {
  DerivativeTable t;
  t.source = "synthetic hover-like test table";
  t.reference = {4.5, 0.004, 1e-4, 1.225, 155.0, 9.81};
  t.mass = {1.75e-4, 1.5e-9, 4.0e-9, 3.5e-9, 0.0};
  const std::vector<std::pair<const char*, double>> d = {
      {"Xu", -0.8}, {"Xw", 0.05}, {"Xq", -0.1}, {"Zu", -0.03}, {"Zw", -1.0}, {"Zq", -0.03},
      {"Mu", 2.4},  {"Mw", -0.2}, {"Mq", -0.9}, {"Yv", -0.7},  {"Yp", 0.1},  {"Yr", 0.02},
      {"Lv", 1.5},  {"Lp", -0.9}, {"Lr", 0.1},  {"Nv", 0.05},  {"Np", -0.1}, {"Nr", -0.6}};
  for (const auto& [k, v] : d) t.at(k) = v;
  t.has_longitudinal = t.has_lateral = true;
  return t;
}

// A table with pseudo-random derivatives (fixed seed), optionally with cross-coupling and Ixz.
inline DerivativeTable random_table(unsigned seed, bool coupling, double ixz_fraction) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  DerivativeTable t = hover_like_table();
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) t.nd(r, c) = u(rng);
  if (!coupling)
    for (const auto& n : coupling_derivative_names()) t.at(n) = 0;
  t.mass.Ixz = ixz_fraction * std::sqrt(t.mass.Ixx * t.mass.Izz);
  t.has_coupling = coupling;
  return t;
}

// Characteristic polynomial coefficients c_0..c_n (c_n = 1) of A by the Faddeev-LeVerrier
// recursion (Faddeev & Faddeeva 1963, Computational Methods of Linear Algebra, sec. 24), in long
// double: M_1 = I, c_{n-k} = -tr(A M_k)/k, M_{k+1} = A M_k + c_{n-k} I.
inline std::vector<long double> characteristic_polynomial(const Eigen::MatrixXd& A) {
  using MatL = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  const int n = int(A.rows());
  const MatL a = A.cast<long double>();
  std::vector<long double> c(n + 1, 0.0L);
  c[n] = 1.0L;
  MatL M = MatL::Identity(n, n);
  for (int k = 1; k <= n; ++k) {
    const MatL AM = a * M;
    c[n - k] = -AM.trace() / k;
    M = AM + c[n - k] * MatL::Identity(n, n);
  }
  return c;
}

// All roots of the monic polynomial sum c_k x^k by Durand-Kerner (Weierstrass) iteration, then
// Newton polishing, in long double.
inline std::vector<std::complex<double>> polynomial_roots(const std::vector<long double>& c) {
  using cl = std::complex<long double>;
  const int n = int(c.size()) - 1;
  auto p = [&](cl x) {
    cl v = c[n];
    for (int k = n - 1; k >= 0; --k) v = v * x + c[k];
    return v;
  };
  auto dp = [&](cl x) {
    cl v = c[n] * (long double)n;
    for (int k = n - 1; k >= 1; --k) v = v * x + c[k] * (long double)k;
    return v;
  };
  long double bound = 0;  // Cauchy bound on |root|
  for (int k = 0; k < n; ++k) bound = std::max(bound, std::abs(c[k]));
  bound += 1;
  std::vector<cl> z(n);
  for (int k = 0; k < n; ++k) z[k] = bound * std::pow(cl(0.4L, 0.9L), (long double)k);
  for (int it = 0; it < 5000; ++it) {
    long double change = 0;
    for (int i = 0; i < n; ++i) {
      cl den = 1;
      for (int j = 0; j < n; ++j)
        if (j != i) den *= z[i] - z[j];
      const cl step = p(z[i]) / den;
      z[i] -= step;
      change = std::max(change, std::abs(step) / std::max(std::abs(z[i]), 1e-30L));
    }
    if (change < 1e-18L) break;
  }
  for (auto& x : z)
    for (int k = 0; k < 3; ++k) {
      const cl d = dp(x);
      if (std::abs(d) > 0) x -= p(x) / d;
    }
  std::vector<std::complex<double>> out;
  for (const auto& x : z) out.emplace_back(double(x.real()), double(x.imag()));
  return out;
}

// Largest relative distance |a_i - b_match(i)| / |b_match(i)| under a greedy nearest matching.
inline double max_relative_mismatch(std::vector<std::complex<double>> a, std::vector<std::complex<double>> b) {
  double worst = a.size() == b.size() ? 0.0 : 1e300;
  for (const auto& x : a) {
    auto it = std::min_element(b.begin(), b.end(), [&](auto p, auto q) { return std::abs(p - x) < std::abs(q - x); });
    if (it == b.end()) return 1e300;
    worst = std::max(worst, std::abs(*it - x) / std::abs(*it));
    b.erase(it);
  }
  return worst;
}

}  // namespace flapstab::test
