// Delay line: stored accepted steps and their cubic Hermite interpolant.
#include "flight/delay_line.hpp"

#include <algorithm>
#include <fmt/format.h>
#include "core/errors.hpp"

namespace flapstab {

void DelayLine::push(double t, const BodyStateVector& x, const BodyStateVector& dx) {
  if (!pts_.empty() && !(t > pts_.back().t)) throw SolveError("DelayLine::push: times must increase");
  pts_.push_back({t, x, dx});
}

BodyStateVector DelayLine::at(double t) const {
  if (pts_.empty() || t < pts_.front().t) return before_(t);
  if (t > pts_.back().t * (1 + 1e-14) + 1e-300)
    throw SolveError(fmt::format("DelayLine::at: t = {} is beyond the stored history (newest {})", t, pts_.back().t));
  if (t >= pts_.back().t) return pts_.back().x;
  const auto it = std::upper_bound(pts_.begin(), pts_.end(), t, [](double v, const Point& p) { return v < p.t; });
  const Point& b = *it;
  const Point& a = *(it - 1);
  const double h = b.t - a.t, s = (t - a.t) / h;
  const double h00 = (1 + 2 * s) * (1 - s) * (1 - s), h10 = s * (1 - s) * (1 - s);
  const double h01 = s * s * (3 - 2 * s), h11 = s * s * (s - 1);
  return h00 * a.x + h10 * h * a.dx + h01 * b.x + h11 * h * b.dx;
}

void DelayLine::forget_before(double t) {
  while (pts_.size() > 2 && pts_[1].t <= t) pts_.pop_front();
}

}  // namespace flapstab
