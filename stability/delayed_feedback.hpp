// Delay-exact linear stability: characteristic roots of delay systems, (gain, latency) maps, Floquet with delay.
//
// Constant coefficients (a retarded linear delay system with discrete delays):
//     x'(t) = A x(t) + sum_j B_j x(t - tau_j),   tau_j >= 0,   A, B_j real n x n.
// Solutions x = v e^(lambda t) exist for the roots of the characteristic equation det Delta(lambda) = 0,
//     Delta(lambda) = lambda I - A - sum_j B_j e^(-lambda tau_j)            (Hale & Verduyn Lunel 1993,
// Introduction to Functional Differential Equations, ch. 1); finitely many lie right of any vertical line,
// and the system is asymptotically stable iff all have Re lambda < 0. They are the eigenvalues of the
// infinitesimal generator of the solution semigroup on C([-tau_max, 0], R^n), discretised here by
// Chebyshev collocation (Breda, Maset & Vermiglio 2005, SIAM J Sci Comput 27:482) and then refined one by
// one by Newton's method on det Delta (Jarlebring 2008, PhD thesis TU Braunschweig; Engelborghs,
// Luzyanina & Roose 2002, ACM TOMS 28:1 -- DDE-BIFTOOL). Only the span of the rows of the B_j is carried
// in the discretised history (docs/theory/delayed-feedback.md: the other components only add spurious
// eigenvalues), so one state-feedback loop of rank r costs n + r N unknowns, not n (N + 1).
//
// Time-periodic coefficients, A(t + T) = A(t), B_j(t + T) = B_j(t):
//     x'(t) = A(t) x(t) + sum_j B_j(t) x(t - tau_j).
// The monodromy operator U maps the history on [-tau_max, 0] to the one on [T - tau_max, T]; its
// eigenvalues (Floquet multipliers) mu decide stability, |mu| < 1 for all (Hale & Verduyn Lunel 1993,
// ch. 8). U is discretised by a semi-discretisation in the sense of Insperger & Stepan (2002, Int J Numer
// Meth Eng 55:503; 2004, Int J Numer Meth Eng 61:117) -- a step-by-step linear map of the history vector
// -- made fourth order: two-stage Gauss-Legendre collocation for the ODE part, cubic Lagrange
// interpolation of the stored history for the delayed terms.
//
// Units are the caller's: lambda in 1 / (unit of t), tau and T in units of t.
#pragma once
#include <complex>
#include <functional>
#include <limits>
#include <vector>
#include <Eigen/Dense>

namespace flapstab {

// One delayed term B x(t - tau).
struct DelayTerm {
  Eigen::MatrixXd B;
  double tau = 0;
};

// x'(t) = A x(t) + sum_j B_j x(t - tau_j).
struct DelaySystem {
  Eigen::MatrixXd A;
  std::vector<DelayTerm> delayed;
};

struct DelayRootsOptions {
  int nodes = 20;           // Chebyshev collocation intervals N on [-tau_max, 0] (N + 1 nodes)
  int max_nodes = 160;      // N grows by 50 % until two discretisations agree, up to this
  double tolerance = 1e-10;  // relative agreement of the refined rightmost roots between two discretisations
  int roots = 6;            // how many rightmost roots to return
  // Compare the discretisation with N against one with 1.5 N (and grow N) before accepting. Off, one
  // discretisation with `nodes` is used: for many calls on a family of systems, check once at the
  // family's hardest member (largest delays and gains) and reuse the accepted `nodes` (stability_map does).
  bool check_convergence = true;
};

struct DelayRoots {
  std::vector<std::complex<double>> roots;  // rightmost first (descending real part), each Newton-refined
  // sigma_min(Delta(lambda)) / (|lambda| + ||A|| + sum_j ||B_j|| e^(-Re lambda tau_j)) after Newton
  std::vector<double> residuals;
  int nodes = 0;  // N of the accepted discretisation (the coarser of the two that agreed); 0 with no delay
  double discretisation_change = std::numeric_limits<double>::quiet_NaN();  // see rightmost_roots
  bool converged = false;  // the check was made and passed (false whenever check_convergence is off)
  double spectral_abscissa() const;  // max Re lambda over the returned roots
};

// Rightmost characteristic roots of det(lambda I - A - sum_j B_j e^(-lambda tau_j)) = 0: Chebyshev
// collocation of the infinitesimal generator (Breda, Maset & Vermiglio 2005), Newton on log det Delta
// with d/dlambda log det Delta = tr(Delta^-1 Delta'), spurious candidates dropped. With every tau_j = 0 the
// roots are the eigenvalues of A + sum_j B_j. discretisation_change: max over the returned roots of the
// distance to the nearest root of the other discretisation, relative to max(|lambda|, 1 / tau_max).
// Cost: one dense eigenproblem of size n + r N per discretisation (n = 5, r = 2, N = 20: 45, about 0.7 ms
// with the check off). SolveError when no candidate converges.
DelayRoots rightmost_roots(const DelaySystem& system, const DelayRootsOptions& options = {});

// A builder of a one-parameter-pair family: the system at (gain, latency). "gain" is whatever scalar
// the builder scales; how the latency enters the delays (and matrices) is the builder's.
using DelaySystemBuilder = std::function<DelaySystem(double gain, double latency)>;

struct StabilityMap {
  std::vector<double> gains, latencies;
  Eigen::MatrixXd abscissa;  // spectral abscissa, rows = gains, cols = latencies; < 0 is stable
  int nodes = 0;             // collocation intervals used at every point
  bool converged = false;    // the discretisation was verified at the largest latency (both end gains)
};

// Spectral abscissa on the grid gains x latencies. With options.check_convergence, the discretisation is
// verified once at (gains.front(), latency_max) and (gains.back(), latency_max) -- the largest delays resolve
// worst -- and the larger accepted N is used everywhere without further checks (when a corner fails, the
// last N tried, max_nodes, with converged = false).
StabilityMap stability_map(const DelaySystemBuilder& build, const std::vector<double>& gains,
                           const std::vector<double>& latencies, const DelayRootsOptions& options = {});

struct CriticalLatency {
  double gain = std::numeric_limits<double>::quiet_NaN();
  bool stable_without_delay = false;
  // Smallest latency at which a root reaches the imaginary axis: NaN when not stable at latency 0,
  // +infinity when stable on all of [0, latency_max].
  double latency = std::numeric_limits<double>::quiet_NaN();
  // omega >= 0 of the crossing root lambda = i omega (0 for a real crossing); NaN when latency is not finite.
  double crossing_frequency = std::numeric_limits<double>::quiet_NaN();
};

// Delay margin: the spectral abscissa scanned on 64 equal latency steps of [0, latency_max], the first
// sign change refined by Newton on det Delta(i omega; tau) = 0 for (omega, tau) (one complex equation, two
// real unknowns; d/dtau Delta by central differences of the builder) to 1e-13 relative, or on the real
// equation det Delta(0; tau) = 0 for a real crossing; bisection on the abscissa if Newton leaves the step.
// An unstable window narrower than latency_max / 64 before the first scanned sign change is not seen.
CriticalLatency critical_latency(const DelaySystemBuilder& build, double gain, double latency_max,
                                 const DelayRootsOptions& options = {});

// The gain in [gmin, gmax] with the largest critical latency: critical_latency on 17 equal gain steps, then
// golden-section search (Kiefer 1953, Proc Am Math Soc 4:502) on the two steps around the best point, to
// 1e-6 (gmax - gmin). Where some gains stay stable up to latency_max (latency +infinity) the middle of the
// widest such run of scan points is returned unrefined.
CriticalLatency best_gain(const DelaySystemBuilder& build, double gmin, double gmax, double latency_max,
                          const DelayRootsOptions& options = {});

// x'(t) = A(t) x(t) + sum_j B[j](t) x(t - tau[j]), A and B[j] period-periodic n x n functions of t.
struct PeriodicDelaySystem {
  double period = 0;
  Eigen::Index n = 0;
  std::function<Eigen::MatrixXd(double)> A;
  std::vector<std::function<Eigen::MatrixXd(double)>> B;
  std::vector<double> tau;
};

struct DelayFloquetOptions {
  int steps_per_period = 80;    // K: steps h = T / K of the semi-discretisation
  bool check_convergence = true;  // compare with K / 2 (and double K until they agree)
  double tolerance = 1e-6;  // estimated error of the dominant multipliers (|mu| >= 0.1 rho), relative to rho
  int max_steps_per_period = 1280;
  int multipliers = 8;          // how many (largest |mu| first) to return
};

struct DelayFloquet {
  std::vector<std::complex<double>> multipliers;  // largest |mu| first
  int steps_per_period = 0;                        // K of the returned multipliers
  Eigen::Index size = 0;                           // dimension of the discretised monodromy matrix
  // max over the returned multipliers with |mu| >= 0.1 rho of |mu_K - mu_(K/2)| (nearest), divided by rho;
  // the method being fourth order, the error of mu_K is about change / 15 (Richardson)
  double change = std::numeric_limits<double>::quiet_NaN();
  bool converged = false;  // the check was made and change / 15 <= tolerance
  double spectral_radius() const;
};

// Floquet multipliers of a periodic delay system from its discretised monodromy matrix (size n + r M,
// r = rank of the delayed terms, M = tau_max / h + 1 or 2 history points), all eigenvalues by a dense
// Eigen::EigenSolver: O((n + r M)^3). n = 4, tau = 3 T, K = 80: rank-one feedback 245 (about 0.06 s),
// a full-rank delayed term 968 (3 to 5 s); the check adds K / 2 (1/8 of that), each doubling of K 8 times.
DelayFloquet delayed_floquet(const PeriodicDelaySystem& system, const DelayFloquetOptions& options = {});

}  // namespace flapstab
