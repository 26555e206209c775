// Eigen-analysis and mode classification: pairing, labels, time scales, eigenvectors, participation.
#include "stability/modes.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "core/errors.hpp"

namespace flapstab {

namespace {

using cplx = std::complex<double>;
constexpr double ln2 = std::numbers::ln2;

// Largest |A_ij|: the scale of every tolerance (1 for a zero matrix).
double matrix_scale(const Eigen::MatrixXd& A) {
  const double s = A.size() ? A.cwiseAbs().maxCoeff() : 0.0;
  return s > 0 ? s : 1.0;
}

// Modal participation factors p_ki = |w_ik v_ki| (Perez-Arriaga, Verghese & Schweppe 1982, IEEE
// Trans PAS-101:3117), w = V^-1 the left eigenvectors: the share of state i in mode k, independent
// of how the states are scaled. Rows: modes; columns: states; each row sums to 1. Falls back to
// normalised eigenvector magnitudes where V is (near) singular, i.e. a defective matrix.
Eigen::MatrixXd participation_factors(const Eigen::MatrixXcd& V, std::string& measure) {
  const Eigen::Index n = V.rows();
  Eigen::MatrixXd P(n, n);
  Eigen::PartialPivLU<Eigen::MatrixXcd> lu(V);
  if (lu.rcond() > 1e-12) {
    const Eigen::MatrixXcd W = lu.inverse();
    for (Eigen::Index k = 0; k < n; ++k)
      for (Eigen::Index i = 0; i < n; ++i) P(k, i) = std::abs(W(k, i) * V(i, k));
    measure = "modal participation factors |w_ik v_ki| with W = V^-1 (Perez-Arriaga et al. 1982), "
              "normalised to sum 1 per mode; independent of state scaling";
  } else {
    for (Eigen::Index k = 0; k < n; ++k)
      for (Eigen::Index i = 0; i < n; ++i) P(k, i) = std::abs(V(i, k));
    measure = "eigenvector magnitudes in non-dimensional states, normalised to sum 1 per mode "
              "(eigenvector matrix singular: participation factors undefined)";
  }
  for (Eigen::Index k = 0; k < n; ++k) {
    const double s = P.row(k).sum();
    if (s > 0) P.row(k) /= s;
  }
  return P;
}

// Scales v so that the attitude component (the larger of theta and phi) is 1, or, where that is
// below `negligible` times the largest component, the largest component. Returns that state's index.
Eigen::Index normalise_eigenvector(Eigen::VectorXcd& v, const std::vector<std::string>& states, double negligible) {
  Eigen::Index largest = 0;
  v.cwiseAbs().maxCoeff(&largest);
  Eigen::Index pivot = -1;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    if ((states[i] == "theta" || states[i] == "phi") && (pivot < 0 || std::abs(v(i)) > std::abs(v(pivot))))
      pivot = i;
  if (pivot < 0 || std::abs(v(pivot)) < negligible * std::abs(v(largest))) pivot = largest;
  v /= v(pivot);
  return pivot;
}

// Times from the nd eigenvalue: t+ values, then seconds (times c/U) and wingbeats (times frequency).
void fill_time_scales(Mode& m, const ReferenceQuantities& ref, double zero_tol) {
  const double tc = ref.time_scale();
  const double f = ref.frequency;
  const cplx lam = m.eigenvalue_nd;
  m.eigenvalue_per_s = lam / tc;
  m.eigenvalue_per_wingbeat = m.eigenvalue_per_s / f;
  const double mag = std::abs(lam);
  m.natural_frequency_nd = mag;
  m.natural_frequency_rad_s = mag / tc;
  m.natural_frequency_hz = m.natural_frequency_rad_s / (2 * pi);
  if (mag > 0 && (m.conjugate_pair || m.kind != ModeKind::neutral)) m.damping_ratio = -lam.real() / mag;
  if (m.kind == ModeKind::oscillatory || (m.kind == ModeKind::neutral && lam.imag() != 0)) {
    m.period_nd = 2 * pi / std::abs(lam.imag());
    m.period_s = *m.period_nd * tc;
    m.period_wingbeats = *m.period_s * f;
  }
  const double sigma = lam.real();
  if (std::abs(sigma) <= zero_tol) return;
  m.time_constant_s = tc / std::abs(sigma);
  const double t_nd = ln2 / std::abs(sigma);
  if (sigma < 0) {
    m.time_to_half_nd = t_nd;
    m.time_to_half_s = t_nd * tc;
    m.time_to_half_wingbeats = t_nd * tc * f;
  } else {
    m.time_to_double_nd = t_nd;
    m.time_to_double_s = t_nd * tc;
    m.time_to_double_wingbeats = t_nd * tc * f;
  }
}

std::string base_label(const Mode& m) {
  switch (m.kind) {
    case ModeKind::oscillatory: return to_string(m.stability) + " oscillatory";
    case ModeKind::subsidence: return "stable subsidence";
    case ModeKind::divergence: return "unstable divergence";
    case ModeKind::neutral: return m.period_nd ? "neutral oscillatory" : "neutral";
  }
  return {};
}

// Ranks modes sharing a base label by |lambda|: fastest "fast", slowest "slow", others
// "intermediate"; a mode alone in its label gets no rank. Writes the final labels.
void rank_and_label(std::vector<Mode>& modes) {
  std::map<std::string, std::vector<Mode*>> groups;
  for (auto& m : modes) groups[base_label(m)].push_back(&m);
  for (auto& [base, group] : groups) {
    std::stable_sort(group.begin(), group.end(),
                     [](const Mode* a, const Mode* b) { return std::abs(a->eigenvalue_nd) > std::abs(b->eigenvalue_nd); });
    for (std::size_t i = 0; i < group.size(); ++i) {
      Mode& m = *group[i];
      m.speed_rank = group.size() < 2 ? "" : i == 0 ? "fast" : i + 1 == group.size() ? "slow" : "intermediate";
      if (m.speed_rank.empty()) {
        m.label = base;
      } else {
        const auto space = base.find(' ');
        m.label = space == std::string::npos ? m.speed_rank + " " + base
                                             : base.substr(0, space) + " " + m.speed_rank + base.substr(space);
      }
    }
  }
}

// The rigid-body motion a state describes and whether it is the attitude (integrated rate) of that motion.
struct StateMotion {
  const char* motion;
  const char* rate;      // the velocity or rate state
  const char* attitude;  // the angle state, or nullptr
};
constexpr StateMotion motion_table[] = {{"pitch", "q", "theta"}, {"roll", "p", "phi"}, {"yaw", "r", "psi"},
                                        {"surge", "u", nullptr}, {"sway", "v", nullptr}, {"heave", "w", nullptr}};

bool known_state(const std::string& s) {
  for (const auto& t : motion_table)
    if (s == t.rate || (t.attitude && s == t.attitude)) return true;
  return false;
}

std::string join_motions(const std::vector<std::string>& motions) {
  std::string s;
  for (const auto& m : motions) s += (s.empty() ? "" : "-") + m;
  return s;
}

// Name without the speed rank (docs/theory/modes.md).
std::string base_name(const Mode& m) {
  const std::string motions = join_motions(m.motions);
  switch (m.kind) {
    case ModeKind::oscillatory: return to_string(m.stability) + " " + motions + " oscillation";
    case ModeKind::subsidence: return motions + " subsidence";
    case ModeKind::divergence: return motions + " divergence";
    case ModeKind::neutral: return "neutral " + motions + (m.period_nd ? " oscillation" : " mode");
  }
  return {};
}

// Motions, their magnitudes and the name of every mode; modes that would share a name are ranked
// fast/slow (intermediate) by |lambda| as the labels are.
void name_modes(StabilityAnalysis& a, double threshold) {
  std::map<std::string, std::vector<Mode*>> groups;
  const double arm = wing_length_in_chords(a.reference);
  for (auto& m : a.modes) {
    const auto motions = mode_motions(m, a.state_order, arm);
    double top = 0;
    for (const auto& [name, z] : motions) top = std::max(top, std::abs(z));
    for (const auto& [name, z] : motions) {
      const double r = top > 0 ? std::abs(z) / top : 0.0;
      m.motion_magnitude.emplace_back(name, r);
      if (r >= threshold) m.motions.push_back(name);
    }
    groups[base_name(m)].push_back(&m);
  }
  for (auto& [base, group] : groups) {
    std::stable_sort(group.begin(), group.end(),
                     [](const Mode* x, const Mode* y) { return std::abs(x->eigenvalue_nd) > std::abs(y->eigenvalue_nd); });
    for (std::size_t i = 0; i < group.size(); ++i)
      group[i]->name = group.size() < 2 ? base
                       : (i == 0 ? "fast " : i + 1 == group.size() ? "slow " : "intermediate ") + base;
  }
}

}  // namespace

double wing_length_in_chords(const ReferenceQuantities& ref) {
  return ref.S_t > 0 && ref.c > 0 ? ref.S_t / (2 * ref.c * ref.c) : 1.0;
}

std::vector<std::pair<std::string, cplx>> mode_motions(const Mode& m, const std::vector<std::string>& states,
                                                       double arm) {
  auto index = [&](const char* s) -> std::optional<std::size_t> {
    if (!s) return std::nullopt;
    const auto it = std::find(states.begin(), states.end(), s);
    if (it == states.end()) return std::nullopt;
    return std::size_t(it - states.begin());
  };
  // Rotations from the rate where it is a state, else lambda+ times the attitude; `raw_attitude` takes the attitude
  // itself (a neutral root: lambda+ = 0, the motion is a pure change of attitude or position).
  auto build = [&](bool raw_attitude) {
    std::vector<std::pair<std::string, cplx>> out;
    for (const auto& t : motion_table) {
      const auto r = index(t.rate), a = index(t.attitude);
      const bool rotation = t.attitude != nullptr;
      const double scale = rotation ? arm : 1.0;
      if (raw_attitude && a) out.emplace_back(t.motion, m.eigenvector[*a]);
      else if (r) out.emplace_back(t.motion, scale * m.eigenvector[*r]);
      else if (a) out.emplace_back(t.motion, scale * m.eigenvalue_nd * m.eigenvector[*a]);
    }
    for (std::size_t i = 0; i < states.size(); ++i)
      if (!known_state(states[i])) out.emplace_back(states[i], m.eigenvector[i]);
    return out;
  };
  auto motions = build(false);
  double top = 0, largest = 0;
  for (const auto& [name, z] : motions) top = std::max(top, std::abs(z));
  for (const auto& z : m.eigenvector) largest = std::max(largest, std::abs(z));
  if (!(top > 1e-12 * largest)) motions = build(true);
  return motions;
}

double mode_similarity(const Mode& a, const std::vector<std::string>& states_a, const Mode& b,
                       const std::vector<std::string>& states_b, double arm_a, double arm_b) {
  const auto ma = mode_motions(a, states_a, arm_a), mb = mode_motions(b, states_b, arm_b);
  double na = 0, nb = 0;
  for (const auto& [n, z] : ma) na += std::norm(z);
  for (const auto& [n, z] : mb) nb += std::norm(z);
  cplx same = 0, conjugate = 0;
  for (const auto& [n, za] : ma)
    for (const auto& [k, zb] : mb)
      if (n == k) same += std::conj(za) * zb, conjugate += std::conj(za) * std::conj(zb);
  if (!(na > 0 && nb > 0)) return 0;
  const double dot = a.conjugate_pair && b.conjugate_pair ? std::max(std::abs(same), std::abs(conjugate)) : std::abs(same);
  return std::min(1.0, dot / std::sqrt(na * nb));
}

std::vector<ModePair> pair_modes(const StabilityAnalysis& a, const StabilityAnalysis& b) {
  struct Candidate {
    std::size_t i, j;
    double s;
  };
  std::vector<Candidate> all;
  const double arm_a = wing_length_in_chords(a.reference), arm_b = wing_length_in_chords(b.reference);
  for (std::size_t i = 0; i < a.modes.size(); ++i)
    for (std::size_t j = 0; j < b.modes.size(); ++j)
      all.push_back({i, j, mode_similarity(a.modes[i], a.state_order, b.modes[j], b.state_order, arm_a, arm_b)});
  std::stable_sort(all.begin(), all.end(), [](const Candidate& x, const Candidate& y) { return x.s > y.s; });
  std::vector<ModePair> out(a.modes.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i].a = i;
  std::vector<bool> used_b(b.modes.size(), false);
  for (const auto& c : all) {
    if (out[c.i].b || used_b[c.j]) continue;
    out[c.i].b = c.j;
    out[c.i].similarity = c.s;
    used_b[c.j] = true;
  }
  return out;
}

std::string to_string(ModeKind k) {
  switch (k) {
    case ModeKind::oscillatory: return "oscillatory";
    case ModeKind::subsidence: return "subsidence";
    case ModeKind::divergence: return "divergence";
    case ModeKind::neutral: return "neutral";
  }
  return {};
}

std::string to_string(ModeStability s) {
  switch (s) {
    case ModeStability::stable: return "stable";
    case ModeStability::unstable: return "unstable";
    case ModeStability::neutral: return "neutral";
  }
  return {};
}

StabilityAnalysis analyse_modes(const StateSpace& sys, const ReferenceQuantities& ref, const ModeOptions& opt) {
  const Eigen::Index n = sys.A.rows();
  if (sys.A.cols() != n || Eigen::Index(sys.state_order.size()) != n)
    throw std::invalid_argument("analyse_modes: A must be square with one name per state");
  if (!sys.A.allFinite()) throw SolveError("analyse_modes: system matrix '" + sys.name + "' is not finite");
  if (!(ref.U > 0 && ref.c > 0 && ref.frequency > 0))
    throw std::invalid_argument("analyse_modes: reference U, c and frequency must be positive");

  StabilityAnalysis out;
  out.name = sys.name;
  out.state_order = sys.state_order;
  out.system_matrix_nd = sys.A;
  out.input_matrix_nd = sys.B;
  out.input_order = sys.input_order;
  out.reference = ref;

  Eigen::EigenSolver<Eigen::MatrixXd> es(sys.A, true);
  if (es.info() != Eigen::Success) throw SolveError("eigen-decomposition of '" + sys.name + "' did not converge");
  const Eigen::VectorXcd lambda = es.eigenvalues();
  const Eigen::MatrixXcd V = es.eigenvectors();
  const Eigen::MatrixXd P = participation_factors(V, out.participation_measure);

  const double scale = matrix_scale(sys.A);
  const double zero_tol = opt.zero_tolerance * scale;
  const double imag_tol = opt.imaginary_tolerance * scale;
  std::vector<bool> used(n, false);
  for (Eigen::Index k = 0; k < n; ++k) {
    if (used[k]) continue;
    used[k] = true;
    cplx lam = lambda(k);
    Eigen::Index col = k;
    Mode m;
    if (std::abs(lam.imag()) > imag_tol) {
      // Pair with the unused root nearest conj(lam), by tolerance, never by exact equality.
      Eigen::Index partner = -1;
      double best = opt.pair_tolerance * scale;
      for (Eigen::Index j = 0; j < n; ++j) {
        if (used[j]) continue;
        const double d = std::abs(lambda(j) - std::conj(lam));
        if (d <= best) best = d, partner = j;
      }
      if (partner < 0) throw SolveError("complex eigenvalue without a conjugate partner in '" + sys.name + "'");
      used[partner] = true;
      if (lam.imag() < 0) col = partner, lam = lambda(partner);
      m.conjugate_pair = true;
    } else {
      lam = cplx(lam.real(), 0.0);  // a real root: drop the numerical imaginary noise
    }
    m.eigenvalue_nd = lam;
    m.stability = lam.real() < -zero_tol ? ModeStability::stable
                  : lam.real() > zero_tol ? ModeStability::unstable
                                          : ModeStability::neutral;
    if (m.stability == ModeStability::neutral) m.kind = ModeKind::neutral;
    else if (m.conjugate_pair) m.kind = ModeKind::oscillatory;
    else m.kind = m.stability == ModeStability::stable ? ModeKind::subsidence : ModeKind::divergence;
    fill_time_scales(m, ref, zero_tol);

    Eigen::VectorXcd v = V.col(col);
    m.normalised_by = sys.state_order[normalise_eigenvector(v, sys.state_order, opt.attitude_negligible)];
    m.eigenvector.assign(v.data(), v.data() + n);
    m.participation.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) m.participation[i] = P(col, i);
    std::vector<Eigen::Index> order(n);
    for (Eigen::Index i = 0; i < n; ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](auto a, auto b) { return P(col, a) > P(col, b); });
    const double top = P(col, order[0]);
    for (auto i : order)
      if (P(col, i) >= opt.dominant_threshold * top) m.dominant_states.push_back(sys.state_order[i]);
    out.modes.push_back(std::move(m));
  }

  rank_and_label(out.modes);
  name_modes(out, opt.motion_threshold);
  std::stable_sort(out.modes.begin(), out.modes.end(), [](const Mode& a, const Mode& b) {
    if (a.eigenvalue_nd.real() != b.eigenvalue_nd.real()) return a.eigenvalue_nd.real() > b.eigenvalue_nd.real();
    return std::abs(a.eigenvalue_nd.imag()) > std::abs(b.eigenvalue_nd.imag());
  });
  return out;
}

}  // namespace flapstab
