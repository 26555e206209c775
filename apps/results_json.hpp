// JSON forms of flapstab's results (trim, derivatives) and the metadata every output file carries.
#pragma once
#include <chrono>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include "cfd/derivatives.hpp"
#include "flight/free_flight.hpp"
#include "trim/trim.hpp"

namespace flapstab {

// Version, conventions, units and the input's hash: the header of every JSON flapstab writes.
nlohmann::json metadata_json(const Case& c, const std::string& command);
// Geometric angle of attack of the right wing at mid-downstroke and mid-upstroke (the instants halfway between the
// stroke reversals, phi minimal and maximal): the angle between the chord line (towards the leading edge) and the
// wing's own velocity perpendicular to the span, the body at rest and no induced flow, in [0, 180] deg (> 90: the
// trailing edge leads). The velocity is that of the span axis at r2 (the same direction at every station: the
// wing is rigid and untwisted). With no deviation rate at mid-stroke it is alpha there on the downstroke and
// 180 deg - alpha on the upstroke (docs/theory/conventions.md). None for revolving wings (no reversals).
struct StrokeIncidence {
  double downstroke = 0, upstroke = 0;               // rad
  double downstroke_phase = 0, upstroke_phase = 0;   // t / T of the two instants, in [0, 1)
};
std::optional<StrokeIncidence> mid_stroke_incidence(const Kinematics& k);

// With `incidence` (mid_stroke_incidence of the trimmed kinematics, in degrees) where the stroke reverses.
nlohmann::json trim_json(const TrimResult& r);
nlohmann::json derivatives_json(const DerivativeResult& d);
nlohmann::json kinematics_json(const Kinematics& k);
// A matrix as a JSON array of rows.
nlohmann::json matrix_json(const Eigen::MatrixXd& m);
// Wall time since t0 (s).
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
// A flight's deviation and growth per wingbeat as run.json "result" keys: deviation_per_wingbeat_nd,
// growth_per_wingbeat, growth_fit_wingbeats, mean_deviation_per_wingbeat_nd, mean_growth_per_wingbeat. Where the fit
// had fewer than two wingbeats with a deviation, the growths are null and growth_note says why.
void put_growth(nlohmann::json& result, const GrowthEstimate& g);
// The same for the terminal, two lines: the deviation from `reference` in the first and last wingbeats, and the
// growth per wingbeat or why it was not fitted.
std::string growth_lines(const GrowthEstimate& g, const std::string& reference);
// FNV-1a 64-bit hash of a file's bytes, as 16 hex digits.
std::string file_hash(const std::string& path);

}  // namespace flapstab
