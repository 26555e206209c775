// Trim parameters applied to kinematics.
#include "trim/parameters.hpp"
#include <cmath>
#include "core/errors.hpp"

namespace flapstab {

namespace {
double refine_extremum(const AngleSeries& s, double tau) {
  for (int i = 0; i < 20; ++i) {
    const SeriesValue v = s.eval(tau);
    if (v.ddf == 0) break;
    const double step = v.df / v.ddf;
    tau -= step;
    if (std::abs(step) < 1e-15) break;
  }
  return s.eval(tau).f;
}
std::vector<WingAngles*> wings(Kinematics& k, ParameterSide side) {
  if (side == ParameterSide::right) return {&k.right};
  if (side == ParameterSide::left) return {&k.left};
  return {&k.right, &k.left};
}
const WingAngles& first_wing(const Kinematics& k, ParameterSide side) {
  return side == ParameterSide::left ? k.left : k.right;
}
}  // namespace

double exact_peak_to_peak(const AngleSeries& s) {
  constexpr int n = 512;
  int imax = 0, imin = 0;
  double fmax = -1e300, fmin = 1e300;
  for (int i = 0; i < n; ++i) {
    const double f = s.eval(double(i) / n).f;
    if (f > fmax) fmax = f, imax = i;
    if (f < fmin) fmin = f, imin = i;
  }
  if (s.is_fourier()) {
    fmax = std::max(fmax, refine_extremum(s, double(imax) / n));
    fmin = std::min(fmin, refine_extremum(s, double(imin) / n));
  }
  return fmax - fmin;
}

std::string TrimParameterization::unit(const std::string& name) { return name == "frequency_hz" ? "Hz" : "deg"; }

TrimParameterization::TrimParameterization(const Kinematics& base, std::vector<TrimParameterSpec> specs,
                                           const std::string& file)
    : base_(base), specs_(std::move(specs)) {
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    const auto& s = specs_[i];
    const std::string key = "trim.parameter[" + std::to_string(i) + "]";
    const bool global = s.name == "frequency_hz" || s.name == "stroke_plane_deg" || s.name == "body_angle_deg";
    if (global && s.side != ParameterSide::both)
      throw InputError(file, key + ".side", "\"" + s.name + "\" applies to the whole insect", "side = \"both\"");
    if (base_.revolving() && (s.name == "stroke_amplitude_deg" || s.name == "stroke_mean_deg" ||
                              s.name == "pitch_amplitude_deg"))
      throw InputError(file, key + ".name", "\"" + s.name + "\" has no meaning for revolving wings",
                       "frequency_hz, pitch_mean_deg, body_angle_deg, stroke_plane_deg or deviation_mean_deg");
    if (s.name == "stroke_amplitude_deg" || s.name == "pitch_amplitude_deg") {
      for (const WingAngles* w : wings(base_, s.side)) {
        const AngleSeries& a = s.name == "stroke_amplitude_deg" ? w->stroke : w->pitch;
        if (exact_peak_to_peak(a) < 1e-9)
          throw InputError(file, key + ".name", "cannot scale the amplitude of a constant angle",
                           "an oscillating angle in [kinematics]");
      }
    }
    initial_.push_back(base_value(s));
  }
}

double TrimParameterization::base_value(const TrimParameterSpec& s) const {
  const WingAngles& w = first_wing(base_, s.side);
  if (s.name == "frequency_hz") return base_.frequency_hz;
  if (s.name == "stroke_plane_deg") return base_.stroke_plane / deg;
  if (s.name == "body_angle_deg") return base_.body_angle / deg;
  if (s.name == "stroke_amplitude_deg") return exact_peak_to_peak(w.stroke) / deg;
  if (s.name == "pitch_amplitude_deg") return exact_peak_to_peak(w.pitch) / deg;
  if (s.name == "stroke_mean_deg") return w.stroke.mean() / deg;
  if (s.name == "pitch_mean_deg") return w.pitch.mean() / deg;
  if (s.name == "deviation_mean_deg") return w.deviation.mean() / deg;
  throw std::logic_error("unknown trim parameter " + s.name);
}

Kinematics TrimParameterization::apply(const std::vector<double>& values) const {
  Kinematics k = base_;
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    const auto& s = specs_[i];
    const double v = values[i], v0 = initial_[i];
    if (s.name == "frequency_hz") k.frequency_hz = v;
    else if (s.name == "stroke_plane_deg") k.stroke_plane = v * deg;
    else if (s.name == "body_angle_deg") k.body_angle = v * deg;
    else {
      for (WingAngles* w : wings(k, s.side)) {
        if (s.name == "stroke_amplitude_deg") w->stroke.scale_oscillation(v / v0);
        else if (s.name == "pitch_amplitude_deg") w->pitch.scale_oscillation(v / v0);
        else if (s.name == "stroke_mean_deg") w->stroke.shift((v - v0) * deg);
        else if (s.name == "pitch_mean_deg") w->pitch.shift((v - v0) * deg);
        else if (s.name == "deviation_mean_deg") w->deviation.shift((v - v0) * deg);
      }
    }
  }
  return k;
}

bool TrimParameterization::one_sided() const {
  for (const auto& s : specs_)
    if (s.side != ParameterSide::both) return true;
  return false;
}

}  // namespace flapstab
