// Richardson extrapolation and the grid-convergence index (grid_convergence.hpp).
#include "core/grid_convergence.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "core/errors.hpp"

namespace flapstab {

namespace {

// Roache's two-grid index with an assumed order and safety factor 3.
void two_grid(GridConvergence& g, double f1, double f2, double r21, double p) {
  const double rp = std::pow(r21, p);
  g.order = p;
  g.order_assumed = true;
  g.safety_factor = 3.0;
  g.extrapolated = (rp * f1 - f2) / (rp - 1);
  g.gci_fine = f1 != 0 ? 3.0 * std::abs((f2 - f1) / f1) / (rp - 1) : 0.0;
  g.extrapolated_error = g.extrapolated != 0 ? std::abs((g.extrapolated - f1) / g.extrapolated) : 0.0;
}

}  // namespace

const char* to_string(GridConvergence::Kind k) {
  switch (k) {
    case GridConvergence::Kind::monotone: return "monotone";
    case GridConvergence::Kind::oscillatory: return "oscillatory";
    case GridConvergence::Kind::diverging: return "diverging";
    case GridConvergence::Kind::two_grids: return "two grids (assumed order)";
    case GridConvergence::Kind::unchanged: return "unchanged";
  }
  return "?";
}

GridConvergence grid_convergence(std::vector<GridValue> grids, double assumed_order) {
  if (grids.size() < 2 || grids.size() > 3)
    throw SolveError(fmt::format("grid convergence: {} grids given; two or three are needed", grids.size()));
  if (!(assumed_order > 0)) throw SolveError("grid convergence: the assumed order must be positive");
  std::sort(grids.begin(), grids.end(), [](const GridValue& a, const GridValue& b) { return a.h < b.h; });
  for (std::size_t i = 0; i < grids.size(); ++i) {
    if (!(grids[i].h > 0) || !std::isfinite(grids[i].value))
      throw SolveError("grid convergence: every grid needs a positive spacing and a finite value");
    if (i > 0 && !(grids[i].h > grids[i - 1].h * (1 + 1e-9)))
      throw SolveError(fmt::format("grid convergence: two grids share the spacing {:g}", grids[i].h));
  }
  GridConvergence g;
  const double f1 = grids[0].value, f2 = grids[1].value, r21 = grids[1].h / grids[0].h;
  g.finest = f1;
  g.extrapolated = f1;
  const double e21 = f2 - f1;
  g.relative_error = f1 != 0 ? std::abs(e21 / f1) : (e21 == 0 ? 0.0 : INFINITY);
  if (grids.size() == 2) {
    g.kind = e21 == 0 ? GridConvergence::Kind::unchanged : GridConvergence::Kind::two_grids;
    if (e21 != 0) two_grid(g, f1, f2, r21, assumed_order);
    return g;
  }
  const double f3 = grids[2].value, r32 = grids[2].h / grids[1].h, e32 = f3 - f2;
  if (e21 == 0 && e32 == 0) return g;  // unchanged on all three
  if (e21 == 0) {
    g.kind = GridConvergence::Kind::unchanged;
    g.note = "the two finest grids give the same value; the coarsest differs";
    return g;
  }
  const double s = e32 / e21 >= 0 ? 1.0 : -1.0;
  const double lr = std::log(std::abs(e32 / e21));
  double p = std::abs(lr) / std::log(r21);
  bool ok = e32 != 0;
  for (int it = 0; ok && it < 200; ++it) {
    const double a = std::pow(r21, p) - s, b = std::pow(r32, p) - s;
    if (!(a > 0) || !(b > 0)) {
      ok = false;
      break;
    }
    const double next = std::abs(lr + std::log(a / b)) / std::log(r21);
    if (!std::isfinite(next)) {
      ok = false;
      break;
    }
    const bool done = std::abs(next - p) < 1e-12 * std::max(1.0, p);
    p = next;
    if (done) break;
  }
  // Monotone convergence of order p > 0 means |e32/e21| = r21^p (r32^p - 1) / (r21^p - 1), which exceeds its p -> 0
  // limit ln r32 / ln r21; a smaller ratio is a change that does not shrink fast enough to be any positive order
  // (the fixed point above takes an absolute value and would still return a p).
  const bool growing = s > 0 && std::abs(e32 / e21) <= std::log(r32) / std::log(r21);
  if (s < 0 || growing || !ok || !(p > 0)) {
    g.kind = s < 0 ? GridConvergence::Kind::oscillatory : GridConvergence::Kind::diverging;
    two_grid(g, f1, f2, r21, assumed_order);
    g.note = s < 0 ? "the grid-to-grid differences change sign (oscillatory convergence): the two finest grids' index "
                     "with the assumed order and safety factor 3"
                   : "the grid-to-grid differences grow as the grid is refined (not in the asymptotic range): the two "
                     "finest grids' index with the assumed order and safety factor 3";
    return g;
  }
  g.kind = GridConvergence::Kind::monotone;
  g.order = p;
  const double rp = std::pow(r21, p);
  g.extrapolated = (rp * f1 - f2) / (rp - 1);
  g.extrapolated_error = g.extrapolated != 0 ? std::abs((g.extrapolated - f1) / g.extrapolated) : 0.0;
  g.gci_fine = 1.25 * g.relative_error / (rp - 1);
  if (p < 0.5 || p > 4)
    g.note = fmt::format("apparent order {:.2f} far from the scheme's (1-2): the grids are probably not in the "
                         "asymptotic range", p);
  return g;
}

}  // namespace flapstab
