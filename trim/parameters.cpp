// Trim parameters applied to kinematics.
#include "trim/parameters.hpp"
#include <algorithm>
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
// The wings a parameter acts on: those of its side, of both pairs (a hind pair's angles change with the fore pair's).
std::vector<WingAngles*> wings(Kinematics& k, ParameterSide side) {
  std::vector<WingAngles*> out;
  if (side != ParameterSide::left) out.push_back(&k.right);
  if (side != ParameterSide::right) out.push_back(&k.left);
  if (k.has_hind) {
    if (side != ParameterSide::left) out.push_back(&k.hind_right);
    if (side != ParameterSide::right) out.push_back(&k.hind_left);
  }
  return out;
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
  // Every Berman-Wang form spans exactly [mean - |amplitude|, mean + |amplitude|] over a cycle.
  if (const BermanWangSeries* b = s.berman_wang()) return 2 * std::abs(b->amplitude);
  if (s.is_fourier()) {
    fmax = std::max(fmax, refine_extremum(s, double(imax) / n));
    fmin = std::min(fmin, refine_extremum(s, double(imin) / n));
  }
  return fmax - fmin;
}

std::string TrimParameterization::unit(const std::string& name) {
  if (name == "frequency_hz") return "Hz";
  if (name == "stroke_shape_k" || name == "pitch_shape_c") return "1";
  return "deg";
}

namespace {
// The angle a Berman-Wang parameter acts on, and whether it exists only in that form.
const AngleSeries& berman_wang_target(const WingAngles& w, const std::string& name) {
  if (name == "stroke_shape_k") return w.stroke;
  if (name == "pitch_shape_c" || name == "pitch_phase_deg") return w.pitch;
  return w.deviation;
}
bool berman_wang_only(const std::string& name) {
  return name == "stroke_shape_k" || name == "pitch_shape_c" || name == "pitch_phase_deg" ||
         name == "deviation_phase_deg";
}
}  // namespace

TrimParameterization::TrimParameterization(const Kinematics& base, std::vector<TrimParameterSpec> specs,
                                           const std::string& file)
    : base_(base), specs_(std::move(specs)) {
  for (std::size_t i = 0; i < specs_.size(); ++i) {
    const auto& s = specs_[i];
    const std::string key = "trim.parameter[" + std::to_string(i) + "]";
    const bool global = s.name == "frequency_hz" || s.name == "stroke_plane_deg" || s.name == "body_angle_deg" ||
                        s.name == "abdomen_flexion_deg";
    if (global && s.side != ParameterSide::both)
      throw InputError(file, key + ".side", "\"" + s.name + "\" applies to the whole insect", "side = \"both\"");
    if (base_.revolving() && (s.name == "stroke_amplitude_deg" || s.name == "stroke_mean_deg" ||
                              s.name == "pitch_amplitude_deg"))
      throw InputError(file, key + ".name", "\"" + s.name + "\" has no meaning for revolving wings",
                       "frequency_hz, pitch_mean_deg, body_angle_deg, stroke_plane_deg or deviation_mean_deg");
    if (berman_wang_only(s.name))
      for (const WingAngles* w : wings(base_, s.side))
        if (!berman_wang_target(*w, s.name).berman_wang())
          throw InputError(file, key + ".name", "\"" + s.name + "\" needs a Berman-Wang angle",
                           "type = \"berman-wang\" for that angle in [kinematics]");
    if (s.name == "stroke_shape_k" && !(s.lower > 0 && s.upper < 1))
      throw InputError(file, key + ".lower", "bounds of K outside (0, 1)", "0 < lower < upper < 1");
    if (s.name == "pitch_shape_c" && !(s.lower > 0 && s.upper <= 1000))
      throw InputError(file, key + ".lower", "bounds of C outside (0, 1000]", "0 < lower < upper <= 1000");
    const std::vector<WingAngles*> acted = wings(base_, s.side);
    const bool bw_deviation = s.name == "deviation_amplitude_deg" &&
                              std::all_of(acted.begin(), acted.end(),
                                          [](const WingAngles* w) { return w->deviation.berman_wang() != nullptr; });
    if (s.name == "stroke_amplitude_deg" || s.name == "pitch_amplitude_deg" ||
        (s.name == "deviation_amplitude_deg" && !bw_deviation)) {
      for (const WingAngles* w : wings(base_, s.side)) {
        const AngleSeries& a = s.name == "stroke_amplitude_deg" ? w->stroke
                               : s.name == "pitch_amplitude_deg" ? w->pitch : w->deviation;
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
  if (s.name == "abdomen_flexion_deg") return base_.abdomen_flexion / deg;
  if (s.name == "stroke_amplitude_deg") return exact_peak_to_peak(w.stroke) / deg;
  if (s.name == "pitch_amplitude_deg") return exact_peak_to_peak(w.pitch) / deg;
  if (s.name == "stroke_mean_deg") return w.stroke.mean() / deg;
  if (s.name == "pitch_mean_deg") return w.pitch.mean() / deg;
  if (s.name == "deviation_mean_deg") return w.deviation.mean() / deg;
  if (s.name == "deviation_amplitude_deg") return exact_peak_to_peak(w.deviation) / deg;
  if (s.name == "stroke_shape_k") return w.stroke.berman_wang()->shape;
  if (s.name == "pitch_shape_c") return w.pitch.berman_wang()->shape;
  if (s.name == "pitch_phase_deg") return w.pitch.berman_wang()->phase / deg;
  if (s.name == "deviation_phase_deg") return w.deviation.berman_wang()->phase / deg;
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
    else if (s.name == "abdomen_flexion_deg") k.abdomen_flexion = v * deg;
    else {
      for (WingAngles* w : wings(k, s.side)) {
        if (s.name == "stroke_amplitude_deg") w->stroke.scale_oscillation(v / v0);
        else if (s.name == "pitch_amplitude_deg") w->pitch.scale_oscillation(v / v0);
        else if (s.name == "stroke_mean_deg") w->stroke.shift((v - v0) * deg);
        else if (s.name == "pitch_mean_deg") w->pitch.shift((v - v0) * deg);
        else if (s.name == "deviation_mean_deg") w->deviation.shift((v - v0) * deg);
        else if (s.name == "deviation_amplitude_deg") {
          // Peak-to-peak, as stroke_amplitude_deg: a Berman-Wang deviation is set directly (it may start at zero
          // amplitude), any other is scaled about its mean.
          if (BermanWangSeries* b = w->deviation.berman_wang()) b->amplitude = std::copysign(0.5 * v * deg, b->amplitude);
          else w->deviation.scale_oscillation(v / v0);
        }
        else if (s.name == "stroke_shape_k") w->stroke.berman_wang()->shape = v;
        else if (s.name == "pitch_shape_c") w->pitch.berman_wang()->shape = v;
        else if (s.name == "pitch_phase_deg") w->pitch.berman_wang()->phase = v * deg;
        else if (s.name == "deviation_phase_deg") w->deviation.berman_wang()->phase = v * deg;
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
