// The equivalent revolving-wing flyer: the same insect with its wings revolving at constant speed
// (the flapping wings' mean speed at r2), fixed pitch (the mean mid-stroke incidence of the flapping wings,
// apps/results_json.hpp mid_stroke_incidence),
// trimmed to the same weight; its modes beside the flapping flyer's.
#pragma once
#include <nlohmann/json.hpp>
#include "cfd/derivatives.hpp"
#include "stability/analysis.hpp"
#include "trim/trim.hpp"

namespace flapstab {

struct RevolvingComparison {
  Case revolving_case;       // the generated case (revolving kinematics, its own [trim])
  TrimResult trim;
  DerivativeResult derivatives;
  StabilityReport stability;
};

// Kinematics of the equivalent revolving flyer for a trimmed flapping flyer: frequency Phi n / pi
// revolutions per second (mean stroke speed equal), pitch = mean mid-stroke incidence, same body
// and stroke-plane angles. Its trim frees frequency (Z), body angle (M) and stroke plane (X).
Case revolving_equivalent(const Case& flapping, const Kinematics& trimmed);

// Trim, derivatives and stability of the equivalent revolving flyer (throws SolveError if its trim fails).
RevolvingComparison compare_with_revolving(const Case& flapping, const Kinematics& trimmed, const AeroModel& model);

// Each flapping mode paired with the revolving flyer's mode of the most similar eigenvector (stability/modes.hpp
// pair_modes), as {flapping_mode, flapping_name, revolving_mode, revolving_name, similarity}.
nlohmann::json mode_pairing_json(const StabilityAnalysis& flapping, const StabilityAnalysis& revolving);

// With `flapping` (the flapping flyer's stability), also `mode_pairing` per analysis.
nlohmann::json revolving_json(const RevolvingComparison& r, const StabilityReport* flapping = nullptr);

}  // namespace flapstab
