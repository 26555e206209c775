// AeroModel helpers: cycle means of wrench histories.
#include "core/aero_model.hpp"
#include <stdexcept>

namespace flapstab {

WrenchSample WrenchHistory::mean_sample() const {
  if (samples.empty()) throw std::logic_error("WrenchHistory::mean of an empty history");
  WrenchSample m;
  for (const auto& s : samples) {
    m.body += s.body;
    m.right += s.right;
    m.left += s.left;
    m.power += s.power;
  }
  const double k = 1.0 / double(samples.size());
  m.body = k * m.body;
  m.right = k * m.right;
  m.left = k * m.left;
  m.power *= k;
  return m;
}

Wrench WrenchHistory::mean() const { return mean_sample().total(); }
double WrenchHistory::mean_power() const { return mean_sample().power; }

WrenchSample AeroModel::instantaneous(const Insect&, const Kinematics&, double, const BodyMotion&) const {
  throw std::logic_error("aerodynamic model '" + name() + "' has memory: no instantaneous loads");
}

}  // namespace flapstab
