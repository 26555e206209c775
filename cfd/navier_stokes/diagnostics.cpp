// Flow diagnostics at the cell centres (diagnostics.hpp).
#include "cfd/navier_stokes/diagnostics.hpp"

#include <algorithm>

namespace flapstab::ns {

CentreFields centre_fields(const Grid& g, const VectorField& u) {
  const Shape s = g.shape();
  const std::size_t n = s.cells();
  CentreFields f;
  for (int d = 0; d < 3; ++d) {
    f.u[d].assign(n, 0.0);
    f.w[d].assign(n, 0.0);
  }
  f.q.assign(n, 0.0);
  auto flat = [&](int i, int j, int k) { return (std::size_t(k - 1) * s.ny + (j - 1)) * s.nx + (i - 1); };
#pragma omp parallel for schedule(static) if (threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        const int I[3] = {i, j, k};
        for (int d = 0; d < 3; ++d) {
          int J[3] = {i, j, k};
          ++J[d];
          f.u[d][flat(i, j, k)] = 0.5 * (u[d](I[0], I[1], I[2]) + u[d](J[0], J[1], J[2]));
        }
      }
  const int nn[3] = {s.nx, s.ny, s.nz};
#pragma omp parallel for schedule(static) if (threaded(s))
  for (int k = 1; k <= s.nz; ++k)
    for (int j = 1; j <= s.ny; ++j)
      for (int i = 1; i <= s.nx; ++i) {
        double G[3][3];  // G[a][b] = d u_a / d x_b
        for (int b = 0; b < 3; ++b) {
          int lo[3] = {i, j, k}, hi[3] = {i, j, k};
          lo[b] = std::max(1, lo[b] - 1);
          hi[b] = std::min(nn[b], hi[b] + 1);
          const double dx = g.axis[b].xc[hi[b]] - g.axis[b].xc[lo[b]];
          for (int a = 0; a < 3; ++a)
            G[a][b] = dx > 0 ? (f.u[a][flat(hi[0], hi[1], hi[2])] - f.u[a][flat(lo[0], lo[1], lo[2])]) / dx : 0.0;
        }
        const std::size_t c = flat(i, j, k);
        f.w[0][c] = G[2][1] - G[1][2];
        f.w[1][c] = G[0][2] - G[2][0];
        f.w[2][c] = G[1][0] - G[0][1];
        double ss = 0, oo = 0;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) {
            const double sym = 0.5 * (G[a][b] + G[b][a]), anti = 0.5 * (G[a][b] - G[b][a]);
            ss += sym * sym;
            oo += anti * anti;
          }
        f.q[c] = 0.5 * (oo - ss);
      }
  return f;
}

}  // namespace flapstab::ns
