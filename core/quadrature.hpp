// Gauss-Legendre quadrature nodes and weights on [-1, 1].
#pragma once
#include <vector>

namespace flapstab {

// n-point Gauss-Legendre rule (Newton on the three-term Legendre recurrence; nodes to 1e-15).
void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w);

}  // namespace flapstab
