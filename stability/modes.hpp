// Eigen-analysis of an LTI system and classification of its natural modes of motion.
//
// Vocabulary (docs/derivative-table.md): a complex pair is `oscillatory`, a stable real root a `subsidence`,
// an unstable real root a `divergence`, a root with |Re| within tolerance of zero `neutral`; labels
// are prefixed `stable`/`unstable` and, where several modes share a label, ranked `fast`/`slow`
// by |lambda| ("intermediate" between them when three or more share it), e.g.
// "stable fast subsidence". All tolerances are relative to the largest |A_ij| (the matrix scale).
#pragma once
#include <complex>
#include <optional>
#include <string>
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

}  // namespace flapstab
