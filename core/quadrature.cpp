// Gauss-Legendre quadrature nodes and weights.
#include "core/quadrature.hpp"
#include <cmath>
#include "core/types.hpp"

namespace flapstab {

void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(std::size_t(n), 0.0);
  w.assign(std::size_t(n), 0.0);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(pi * (i + 0.75) / (n + 0.5));
    double dp = 1;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (z * p1 - p0) / (z * z - 1);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) <= 1e-15) break;
    }
    x[std::size_t(i)] = z;
    w[std::size_t(i)] = 2 / ((1 - z * z) * dp * dp);
  }
}

}  // namespace flapstab
