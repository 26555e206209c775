// History of the body state for delayed measurements: cubic Hermite interpolation between accepted steps.
#pragma once
#include <deque>
#include <functional>
#include "core/eom.hpp"

namespace flapstab {

class DelayLine {
 public:
  // before_start(t) gives the state for t < the first stored time (the initial function of the delay system).
  explicit DelayLine(std::function<BodyStateVector(double)> before_start) : before_(std::move(before_start)) {}
  // Appends an accepted point (times strictly increasing).
  void push(double t, const BodyStateVector& x, const BodyStateVector& dx);
  // State at time t <= the newest stored time: Hermite cubic through the neighbouring points (x and dx/dt),
  // before_start before the first point. Throws SolveError for t beyond the newest point.
  BodyStateVector at(double t) const;
  // Drops points older than t, keeping the one at or before it.
  void forget_before(double t);
  bool empty() const { return pts_.empty(); }
  double newest() const { return pts_.back().t; }

 private:
  struct Point {
    double t;
    BodyStateVector x, dx;
  };
  std::function<BodyStateVector(double)> before_;
  std::deque<Point> pts_;
};

}  // namespace flapstab
