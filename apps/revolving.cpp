// The equivalent revolving-wing flyer and its modes.
#include "apps/revolving.hpp"

#include <algorithm>
#include <fmt/format.h>

#include "apps/results_json.hpp"
#include "apps/stability_json.hpp"
#include "core/errors.hpp"

namespace flapstab {

Case revolving_equivalent(const Case& flapping, const Kinematics& trimmed) {
  Case c = flapping;
  c.path = flapping.path + " (equivalent revolving-wing flyer)";
  if (flapping.insect.hind_wing)
    throw InputError(flapping.path, "hind_wing", "the revolving-wing equivalent is defined for one wing pair",
                     "a two-winged insect for the revolving-wing comparison");
  Kinematics& k = c.kinematics;
  k = trimmed;
  // Mean |dphi/dt| of a flapping stroke = 2 Phi n; a revolution per cycle sweeps 2 pi n.
  k.frequency_hz = trimmed.stroke_amplitude() * trimmed.frequency_hz / pi;
  // Mean of the mid-downstroke and mid-upstroke geometric incidences (alpha and 180 deg - alpha at mid-stroke).
  const auto mid = mid_stroke_incidence(trimmed);
  if (!mid) throw InputError(flapping.path, "kinematics", "has no stroke reversals", "flapping kinematics");
  const double incidence = 0.5 * (mid->downstroke + mid->upstroke);
  k.right.stroke = FourierSeries{0.0, {}, {}, 2 * pi};
  k.right.deviation = FourierSeries{};
  k.right.pitch = FourierSeries{std::clamp(incidence, 1 * deg, 90 * deg), {}, {}};
  k.left = k.right;
  const double n = k.frequency_hz, chi = k.body_angle / deg, beta = k.stroke_plane / deg;
  c.trim.parameters = {
      {"frequency_hz", 0.3 * n, 3.0 * n, ParameterSide::both},
      {"body_angle_deg", std::max(-89.0, chi - 40), std::min(89.0, chi + 40), ParameterSide::both},
      {"stroke_plane_deg", std::max(-89.0, beta - 40), std::min(89.0, beta + 40), ParameterSide::both}};
  c.trim.objective = "least-change";
  return c;
}

RevolvingComparison compare_with_revolving(const Case& flapping, const Kinematics& trimmed, const AeroModel& model) {
  RevolvingComparison r;
  r.revolving_case = revolving_equivalent(flapping, trimmed);
  r.trim = trim_hover(r.revolving_case, model);
  if (!r.trim.converged)
    throw SolveError(fmt::format("{}: the equivalent revolving-wing flyer did not trim ({}; residuals {:.2e}, {:.2e})",
                                 flapping.path, r.trim.message, r.trim.relative_force_residual,
                                 r.trim.relative_moment_residual));
  r.derivatives = cycle_averaged_derivatives(model, r.revolving_case.insect, r.trim.kinematics, r.revolving_case.fluid,
                                             r.revolving_case.derivatives.relative_step);
  StabilityRequest req;
  req.six_dof = true;
  r.stability = analyse_stability(r.derivatives.table, req);
  return r;
}

nlohmann::json mode_pairing_json(const StabilityAnalysis& flapping, const StabilityAnalysis& revolving) {
  nlohmann::json j = nlohmann::json::array();
  for (const ModePair& p : pair_modes(flapping, revolving)) {
    const Mode& f = flapping.modes[p.a];
    j.push_back({{"flapping_mode", p.a},
                 {"flapping_name", f.name},
                 {"revolving_mode", p.b ? nlohmann::json(*p.b) : nlohmann::json(nullptr)},
                 {"revolving_name", p.b ? nlohmann::json(revolving.modes[*p.b].name) : nlohmann::json(nullptr)},
                 {"similarity", p.similarity}});
  }
  return j;
}

nlohmann::json revolving_json(const RevolvingComparison& r, const StabilityReport* flapping) {
  nlohmann::json pairing = nlohmann::json::object();
  if (flapping) {
    if (flapping->longitudinal && r.stability.longitudinal)
      pairing["longitudinal"] = mode_pairing_json(*flapping->longitudinal, *r.stability.longitudinal);
    if (flapping->lateral && r.stability.lateral)
      pairing["lateral"] = mode_pairing_json(*flapping->lateral, *r.stability.lateral);
  }
  return {{"mode_pairing", pairing},
          {"mode_pairing_note", "each flapping mode (index in the flapping analysis) beside the revolving flyer's mode "
                                "of the most similar eigenvector (greedy-best one-to-one pairing; similarity "
                                "|m_a^H m_b| / (|m_a| |m_b|) of the motion vectors, docs/theory/modes.md)"},
          {"description",
           "equivalent revolving-wing flyer: same insect, wings revolving at the flapping wings' mean stroke speed "
           "with fixed pitch equal to the mean of the flapping mid-downstroke and mid-upstroke incidences, trimmed to the "
           "same weight "
           "(frequency, body angle, stroke plane)"},
          {"pitch_deg", r.trim.kinematics.right.pitch.eval(0).f / deg},
          {"trim", trim_json(r.trim)},
          {"derivatives", derivatives_json(r.derivatives)},
          {"stability", to_json(r.stability)}};
}

}  // namespace flapstab
