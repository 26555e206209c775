// JSON forms of trim and derivative results, and a flight's growth per wingbeat (with its terminal lines).
#include "apps/results_json.hpp"
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <iterator>
#include "core/series.hpp"

#include "core/hash.hpp"
#include "core/rotation.hpp"

namespace flapstab {

using nlohmann::json;

std::string file_hash(const std::string& path) { return fnv1a64_file(path); }

json matrix_json(const Eigen::MatrixXd& m) {
  json j = json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index k = 0; k < m.cols(); ++k) row.push_back(m(i, k));
    j.push_back(row);
  }
  return j;
}

json metadata_json(const Case& c, const std::string& command) {
  return {{"program", "flapstab"},
          {"version", FLAPSTAB_VERSION},
          {"command", command},
          {"case_file", c.path},
          {"case_fnv1a64", file_hash(c.path)},
          {"insect", c.insect.name},
          {"aero_model", c.aero.model},
          {"conventions",
           {{"axes", "hover stability axes: body-fixed, origin at the wingbeat-mean centre of mass, x forward and "
                     "horizontal at trim, y right, z down; gravity +z"},
            {"units", "SI unless a key says otherwise (_deg, _nd)"},
            {"nondimensionalisation",
             "U = 2 Phi n r2, c = mean chord, S_t = both wings; forces / (rho U^2 S_t / 2), moments / (rho U^2 S_t c "
             "/ 2), velocities / U, rates * c / U"}}}};
}

json kinematics_json(const Kinematics& k) {
  auto angle = [](const AngleSeries& a) {
    json j;
    if (const FourierSeries* f = a.fourier()) {
      std::vector<double> c, s;
      for (double x : f->a) c.push_back(x / deg);
      for (double x : f->b) s.push_back(x / deg);
      j = {{"type", "fourier"}, {"mean_deg", f->mean / deg}, {"cos_deg", c}, {"sin_deg", s}};
      if (f->rate != 0) j["rate_deg_per_cycle"] = f->rate / deg;
    } else if (const BermanWangSeries* b = a.berman_wang()) {
      j = {{"type", "berman-wang"}, {"amplitude_deg", b->amplitude / deg}, {"mean_deg", b->mean / deg},
           {"phase_deg", b->phase / deg}};
      if (b->form == BermanWangSeries::Form::stroke) j["shape_k"] = b->shape;
      else if (b->form == BermanWangSeries::Form::pitch) j["shape_c"] = b->shape;
      else j["harmonic"] = b->harmonic;
    } else {
      std::vector<double> v, d;
      for (double x : a.hermite()->values) v.push_back(x / deg);
      for (double x : a.hermite()->slopes) d.push_back(x / deg);
      j = {{"type", "hermite"}, {"values_deg", v}, {"slopes_deg_per_cycle", d}};
    }
    return j;
  };
  auto wing = [&](const WingAngles& w) {
    return json{{"stroke", angle(w.stroke)}, {"deviation", angle(w.deviation)}, {"pitch", angle(w.pitch)}};
  };
  json out = {{"frequency_hz", k.frequency_hz},
          {"stroke_plane_deg", k.stroke_plane / deg},
          {"body_angle_deg", k.body_angle / deg},
          {"stroke_plane_reference", k.stroke_plane_on_body ? "body" : "horizontal"},
          {"stroke_amplitude_deg", k.stroke_amplitude() / deg},
          {"right", wing(k.right)},
          {"left", wing(k.left)}};
  if (k.abdomen_flexion != 0) out["abdomen_flexion_deg"] = k.abdomen_flexion / deg;
  if (k.has_hind) {
    out["hind"] = {{"phase_deg", k.hind_phase * 360}, {"right", wing(k.hind_right)}, {"left", wing(k.hind_left)}};
  }
  return out;
}

std::optional<StrokeIncidence> mid_stroke_incidence(const Kinematics& k) {
  if (k.revolving() || !(k.frequency_hz > 0)) return std::nullopt;
  auto state = [&](double tau) { return k.angles(Side::right, tau / k.frequency_hz); };
  // The reversals: phi sampled over the cycle, the extreme sample refined by a parabola through its neighbours.
  constexpr int N = 1440;
  std::vector<double> phi(N);
  for (int j = 0; j < N; ++j) phi[std::size_t(j)] = state(double(j) / N).phi;
  auto extreme = [&](bool maximum) {
    int best = 0;
    for (int j = 1; j < N; ++j)
      if (maximum ? phi[std::size_t(j)] > phi[std::size_t(best)] : phi[std::size_t(j)] < phi[std::size_t(best)]) best = j;
    const double a = phi[std::size_t((best + N - 1) % N)], b = phi[std::size_t(best)], c = phi[std::size_t((best + 1) % N)];
    const double curvature = a - 2 * b + c;
    const double shift = curvature != 0 ? std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5) : 0.0;
    return (best + shift) / N;
  };
  const double t_min = extreme(false), t_max = extreme(true);
  if (t_min == t_max) return std::nullopt;  // no stroke
  auto wrap = [](double t) { return t - std::floor(t); };
  // Span direction e_s and chord direction e_c in the stroke-plane frame: W -> P is Rz(-phi) Rx(-theta) Ry(alpha).
  auto incidence = [&](double tau) {
    auto axes = [&](double t) {
      const WingAngleState a = state(t);
      return Mat3(rot_z(-a.phi) * rot_x(-a.theta) * rot_y(a.alpha));
    };
    const double h = 1e-6;
    const Vec3 span_velocity = (axes(tau + h).col(1) - axes(tau - h).col(1)) / (2 * h);  // d e_s / d tau
    const Mat3 R = axes(tau);
    const Vec3 e_s = R.col(1), e_c = R.col(0);
    const Vec3 v = span_velocity - span_velocity.dot(e_s) * e_s;
    return std::acos(std::clamp(e_c.dot(v) / v.norm(), -1.0, 1.0));
  };
  StrokeIncidence out;
  out.downstroke_phase = wrap(t_min + 0.5 * wrap(t_max - t_min));
  out.upstroke_phase = wrap(t_max + 0.5 * wrap(t_min - t_max));
  out.downstroke = incidence(out.downstroke_phase);
  out.upstroke = incidence(out.upstroke_phase);
  return out;
}

namespace {
json incidence_json(const Kinematics& k) {
  const auto i = mid_stroke_incidence(k);
  if (!i) return nullptr;
  return {{"mid_downstroke_deg", i->downstroke / deg},
          {"mid_upstroke_deg", i->upstroke / deg},
          {"mid_downstroke_phase", i->downstroke_phase},
          {"mid_upstroke_phase", i->upstroke_phase},
          {"definition",
           "geometric angle of attack of the right wing: the angle between the chord (towards the leading edge) and "
           "the wing's velocity relative to the body perpendicular to the span, at r2 (no induced flow), at the "
           "instants halfway between the stroke reversals (phase t/T); < 90 deg: leading edge first; equals alpha "
           "at mid-downstroke and 180 deg - alpha at mid-upstroke when the deviation rate is zero there"}};
}
}  // namespace

json trim_json(const TrimResult& r) {
  json params = json::array();
  for (const auto& p : r.parameters)
    params.push_back({{"name", p.label}, {"unit", p.unit}, {"value", p.value}, {"initial", p.initial},
                      {"lower", p.lower}, {"upper", p.upper}});
  return {{"converged", r.converged},
          {"solved", r.solved},
          {"solver", r.solver},
          {"objective", r.objective},
          {"message", r.message},
          {"iterations", r.iterations},
          {"model_runs", r.model_runs},
          {"equations", r.equations},
          {"parameters", params},
          {"residuals",
           {{"force_N", {r.force_residual.x(), r.force_residual.y(), r.force_residual.z()}},
            {"moment_N_m", {r.moment_residual.x(), r.moment_residual.y(), r.moment_residual.z()}},
            {"force_relative_to_weight", r.relative_force_residual},
            {"moment_relative_to_weight_times_wing_length", r.relative_moment_residual}}},
          {"weight_N", r.weight},
          {"mean_aerodynamic_power_W", r.mean_power},
          {"incidence", incidence_json(r.kinematics)},
          {"kinematics", kinematics_json(r.kinematics)}};
}

json derivatives_json(const DerivativeResult& d) {
  static const char* rows = "XYZLMN";
  static const char* cols[] = {"u", "v", "w", "p", "q", "r"};
  json nd, si, asym, se = json::object();
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const std::string name = std::string(1, rows[i]) + cols[j];
      nd[name] = d.table.nd(i, j);
      si[name] = d.si(i, j);
      asym[name] = d.asymmetry(i, j);
      if (d.standard_error_nd(i, j) >= 0) se[name] = d.standard_error_nd(i, j);
    }
  const auto& ref = d.table.reference;
  const auto& m = d.table.mass;
  json control = json::object();
  for (const auto& c : d.table.control) {
    json col = {{"unit", c.unit}};
    for (int i = 0; i < 6; ++i) col[std::string(1, rows[i])] = c.nd(i);
    control[c.parameter] = col;
  }
  return {{"control_nondimensional", control},
          {"control_note", "d[X Y Z L M N]+ per unit of each kinematic parameter (deg or Hz), moments about the trimmed "
                           "reference point including the gravitational moment of the centre of mass it moves"},
          {"reference", {{"U_m_s", ref.U}, {"c_m", ref.c}, {"S_t_m2", ref.S_t}, {"rho_kg_m3", ref.rho},
                         {"frequency_hz", ref.frequency}, {"g_m_s2", ref.g}}},
          {"mass", {{"m_kg", m.m}, {"Ixx_kg_m2", m.Ixx}, {"Iyy_kg_m2", m.Iyy}, {"Izz_kg_m2", m.Izz},
                    {"Ixz_kg_m2", m.Ixz}}},
          {"planes", {{"longitudinal", d.table.has_longitudinal}, {"lateral", d.table.has_lateral}}},
          {"nondimensional", nd},
          {"standard_error_nondimensional", se},
          {"standard_error_note", "where the model's runs carry one (CFD): an upper bound of each derivative's "
                                  "standard error from its two runs' standard errors of the mean difference from the "
                                  "continued hover (all three force or moment components taken together)"},
          {"si", si},
          {"linearity_asymmetry", asym},
          {"linearity_note", "|(W+ - W0) + (W- - W0)| / |W+ - W-| per derivative: 0 for a linear response"},
          {"si_units", "X, Y, Z in N and L, M, N in N m; per m/s for u, v, w and per rad/s for p, q, r"},
          {"velocity_step_m_s", d.velocity_step},
          {"rate_step_rad_s", d.rate_step},
          {"model_runs", d.model_runs},
          {"source", d.table.source}};
}

namespace {

std::string growth_not_fitted(const GrowthEstimate& g) {
  return fmt::format("not fitted: the fit over wingbeats {}-{} (the second half of the flight) needs a nonzero "
                     "deviation in at least two of them; fly more wingbeats (--wingbeats or [flight] wingbeats)",
                     std::max(g.first, 0), g.last);
}

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

void put_growth(nlohmann::json& result, const GrowthEstimate& g) {
  result["deviation_per_wingbeat_nd"] = g.deviation;
  result["growth_per_wingbeat"] = finite_or_null(g.per_wingbeat);
  result["growth_fit_wingbeats"] = {g.first, g.last};
  result["mean_deviation_per_wingbeat_nd"] = g.mean_deviation;
  result["mean_deviation_note"] = "largest non-dimensional |wingbeat mean of the deviation| over the moving states";
  result["mean_growth_per_wingbeat"] = finite_or_null(g.mean_per_wingbeat);
  if (!std::isfinite(g.per_wingbeat)) result["growth_note"] = growth_not_fitted(g);
}

std::string growth_lines(const GrowthEstimate& g, const std::string& reference) {
  std::string s = fmt::format("  deviation from the {}: {:.3e} (first wingbeat) -> {:.3e} (last)", reference,
                              g.deviation.empty() ? 0.0 : g.deviation.front(),
                              g.deviation.empty() ? 0.0 : g.deviation.back());
  if (!std::isfinite(g.per_wingbeat)) return s + "\n  growth per wingbeat " + growth_not_fitted(g) + "\n";
  s += fmt::format("; growth {:+.4f} per wingbeat (fit over wingbeats {}-{})\n", g.per_wingbeat, g.first, g.last);
  if (!g.mean_deviation.empty() && std::isfinite(g.mean_per_wingbeat))
    s += fmt::format("  wingbeat means of the deviation: {:.3e} -> {:.3e}; growth {:+.4f} per wingbeat (same fit)\n",
                     g.mean_deviation.front(), g.mean_deviation.back(), g.mean_per_wingbeat);
  return s;
}

}  // namespace flapstab
