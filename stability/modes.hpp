// Eigen-analysis of an LTI system and classification of its natural modes of motion.
//
// Vocabulary (docs/derivative-table.md): a complex pair is `oscillatory`, a stable real root a `subsidence`,
// an unstable real root a `divergence`, a root with |Re| within tolerance of zero `neutral`; labels
// are prefixed `stable`/`unstable` and, where several modes share a label, ranked `fast`/`slow`
// by |lambda| ("intermediate" between them when three or more share it), e.g.
// "stable fast subsidence". All tolerances are relative to the largest |A_ij| (the matrix scale).
//
// Besides that label, each mode gets a physical name that does not depend on which other modes share
// its table (docs/theory/modes.md): the rigid-body motions its eigenvector moves, in comparable
// non-dimensional units, and its root type, e.g. "unstable pitch-surge oscillation", "heave subsidence",
// "roll-sway divergence". pair_modes matches the modes of two analyses (averaged and Floquet, flapping
// and revolving, a subsystem and the coupled 6DoF system) by eigenvector similarity.
#pragma once
#include <complex>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include "core/derivative_table.hpp"
#include "stability/lti.hpp"

namespace flapstab {

enum class ModeKind { oscillatory, subsidence, divergence, neutral };
enum class ModeStability { stable, unstable, neutral };

std::string to_string(ModeKind k);
std::string to_string(ModeStability s);

// One natural mode. A complex-conjugate pair is one mode, reported by its member with Im > 0.
struct Mode {
  std::complex<double> eigenvalue_nd;           // lambda+ (per unit t+ = t U / c)
  std::complex<double> eigenvalue_per_s;        // lambda+ U / c (1/s)
  std::complex<double> eigenvalue_per_wingbeat; // lambda per_s / frequency (per wingbeat period)
  bool conjugate_pair = false;
  ModeKind kind = ModeKind::neutral;
  ModeStability stability = ModeStability::neutral;
  std::string speed_rank;                       // "fast" | "slow" | "intermediate" | "" (alone)
  std::string label;                            // e.g. "unstable oscillatory", "stable slow subsidence"

  std::optional<double> damping_ratio;          // -Re/|lambda|; none for a zero root
  double natural_frequency_nd = 0;              // |lambda+| (as MATLAB/python-control damp)
  double natural_frequency_rad_s = 0;           // |lambda| (rad/s)
  double natural_frequency_hz = 0;              // |lambda| / 2 pi
  // Oscillatory modes only: 2 pi / |Im lambda|.
  std::optional<double> period_nd, period_s, period_wingbeats;
  // 1/|Re lambda| and ln 2/|Re lambda|: time to half (stable) or to double (unstable); none if neutral.
  std::optional<double> time_constant_s;
  std::optional<double> time_to_half_nd, time_to_half_s, time_to_half_wingbeats;
  std::optional<double> time_to_double_nd, time_to_double_s, time_to_double_wingbeats;

  // Eigenvector in the non-dimensional states, scaled so that the attitude component (theta or phi,
  // the larger) is 1, or, where that is negligible, the largest component.
  std::vector<std::complex<double>> eigenvector;
  std::string normalised_by;                    // the state whose component is 1
  // Participation of each state (sums to 1) and the states whose participation is at least
  // ModeOptions::dominant_threshold times the largest, largest first.
  std::vector<double> participation;
  std::vector<std::string> dominant_states;

  // Physical name (docs/theory/modes.md), e.g. "unstable pitch-surge oscillation", "heave subsidence":
  // the named motions in the fixed order pitch, roll, yaw, surge, sway, heave, then the root type
  // (oscillation, prefixed stable/unstable; subsidence; divergence; neutral mode), prefixed fast/slow
  // only where several modes of one analysis would carry the same name.
  std::string name;
  std::vector<std::string> motions;              // the named motions, in that order
  // Size of each rigid-body motion of the mode relative to its largest (1), in comparable non-dimensional
  // units (see mode_motions), in the fixed order; only the motions the states describe.
  std::vector<std::pair<std::string, double>> motion_magnitude;
};

struct ModeOptions {
  // |Re lambda| <= zero_tolerance * scale: neutral (neither stable nor unstable).
  double zero_tolerance = 1e-9;
  // |Im lambda| <= imaginary_tolerance * scale: a real root (numerical noise on a real or repeated
  // root, e.g. 1e-13 i, never makes a mode oscillatory).
  double imaginary_tolerance = 1e-7;
  // A complex root pairs with the root nearest its conjugate, within pair_tolerance * scale.
  double pair_tolerance = 1e-6;
  // Attitude component below this fraction of the largest component: normalise by the largest.
  double attitude_negligible = 1e-3;
  // A state is dominant when its participation is at least this fraction of the largest.
  double dominant_threshold = 0.2;
  // A motion is named when its magnitude is at least this fraction of the largest motion's.
  double motion_threshold = 0.3;
};

struct StabilityAnalysis {
  std::string name;                       // "longitudinal" | "lateral" | "6dof"
  std::vector<std::string> state_order;
  Eigen::MatrixXd system_matrix_nd;
  Eigen::MatrixXd input_matrix_nd;        // B of the state space (one column per control input; may be empty)
  std::vector<std::string> input_order;
  ReferenceQuantities reference;          // for the dimensional conversions
  std::string participation_measure;      // how `participation` was computed (see modes.cpp)
  std::vector<Mode> modes;                // most unstable first (Re lambda descending)
};

// Eigenvalues and eigenvectors of sys.A (Eigen::EigenSolver), paired, classified, ranked and
// converted to seconds (reference.U, reference.c) and wingbeats (reference.frequency).
StabilityAnalysis analyse_modes(const StateSpace& sys, const ReferenceQuantities& reference,
                                const ModeOptions& options = {});

// The rigid-body motions of a mode in comparable non-dimensional units: translations as velocities u/U
// (surge), v/U (sway), w/U (heave); rotations as the velocity they give the wing tip, R/c times q c/U (pitch),
// p c/U (roll), r c/U (yaw), the rate taken as lambda+ theta (lambda+ phi, lambda+ psi) where it is not a state.
// `wing_length` is R/c (wing_length_in_chords). A state of another name is its own motion. Complex components
// (the eigenvector's), in the fixed order pitch, roll, yaw, surge, sway, heave.
std::vector<std::pair<std::string, std::complex<double>>> mode_motions(const Mode& m,
                                                                       const std::vector<std::string>& states,
                                                                       double wing_length = 1.0);

// One wing's length in mean chords, R/c = S_t / (2 c^2) (S_t = 2 R c for any planform); 1 where S_t or c is unset.
double wing_length_in_chords(const ReferenceQuantities& reference);

// Eigenvector similarity |m_a^H m_b| / (|m_a| |m_b|) of the motion vectors (mode_motions, each with its own
// wing length) on the motions both describe, the norms over all of each: 1 for the same shape, 0 for motions in
// different states. Two oscillatory modes compare with either member of the other's conjugate pair (the larger).
double mode_similarity(const Mode& a, const std::vector<std::string>& states_a, const Mode& b,
                       const std::vector<std::string>& states_b, double wing_length_a = 1.0,
                       double wing_length_b = 1.0);

// A mode of analysis `a` and its partner in `b` (none when b has fewer modes).
struct ModePair {
  std::size_t a = 0;
  std::optional<std::size_t> b;
  double similarity = 0;
};

// One-to-one pairing of a's modes with b's by eigenvector similarity (wing lengths from each analysis' reference),
// greedy-best: the most similar free
// pair first, then the next, until one side is used up. One entry per mode of a, in a's order.
std::vector<ModePair> pair_modes(const StabilityAnalysis& a, const StabilityAnalysis& b);

}  // namespace flapstab
