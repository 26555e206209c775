// Wing kinematics evaluation.
#include "core/kinematics.hpp"
#include <cmath>

namespace flapstab {

WingAngleState Kinematics::angles(Side s, double t, Pair pair) const {
  const WingAngles& w = wing(s, pair);
  const double tau = t * frequency_hz + (pair == Pair::hind ? hind_phase : 0.0), n = frequency_hz, n2 = n * n;
  const SeriesValue p = w.stroke.eval(tau), d = w.deviation.eval(tau), a = w.pitch.eval(tau);
  return {p.f, d.f, a.f, p.df * n, d.df * n, a.df * n, p.ddf * n2, d.ddf * n2, a.ddf * n2};
}

bool Kinematics::symmetric() const {
  for (int i = 0; i < 64; ++i) {
    const double tau = (i + 0.37) / 64.0;
    for (auto [l, r] : {std::pair{&left.stroke, &right.stroke}, std::pair{&left.deviation, &right.deviation},
                        std::pair{&left.pitch, &right.pitch}, std::pair{&hind_left.stroke, &hind_right.stroke},
                        std::pair{&hind_left.deviation, &hind_right.deviation},
                        std::pair{&hind_left.pitch, &hind_right.pitch}}) {
      if (std::abs(l->eval(tau).f - r->eval(tau).f) > 1e-14) return false;
    }
  }
  return true;
}

double Kinematics::stroke_amplitude() const {
  auto amp = [](const AngleSeries& s) { return s.revolving() ? 0.5 * std::abs(s.fourier()->rate) : s.peak_to_peak(); };
  return 0.5 * (amp(right.stroke) + amp(left.stroke));
}

}  // namespace flapstab
