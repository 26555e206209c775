// Floquet analysis of a time-periodic linear system x' = A(t) x, A(t + T) = A(t): monodromy, multipliers, modes.
//
// Floquet's theorem (e.g. Nayfeh & Mook 1979, Nonlinear Oscillations, ch. 5): the fundamental matrix
// Phi(t) of Phi' = A(t) Phi, Phi(0) = I, after one period is the monodromy M = Phi(T); its eigenvalues
// are the Floquet multipliers mu, the exponents lambda = log(mu) / T (principal branch), and
// M v = mu v gives the Floquet mode's initial state v. |mu| > 1 (Re lambda > 0) is unstable.
// For hover, lambda is reported per second, non-dimensional (times c / U, docs/derivative-table.md) and per
// wingbeat (lambda T = log mu); modes are labelled by stability/modes.hpp applied to the exponent
// matrix B = V diag(lambda) V^-1 (M = exp(B T)), whose eigenvalues are the exponents and whose
// eigenvectors are M's, so the LTI vocabulary carries over unchanged (docs/theory/floquet.md).
#pragma once
#include <complex>
#include <functional>
#include <string>
#include <vector>
#include <Eigen/Dense>
#include "core/derivative_table.hpp"
#include "stability/modes.hpp"

namespace flapstab {

// A periodic matrix function sampled at N equally spaced phases t_k = k T / N (k = 0..N-1),
// interpolated entry by entry with periodic cubic splines (4th-order accurate in T / N).
class PeriodicMatrixSpline {
 public:
  PeriodicMatrixSpline(double period, std::vector<Eigen::MatrixXd> samples);
  Eigen::MatrixXd operator()(double t) const;
  double period() const { return period_; }
  Eigen::Index rows() const { return y_.front().rows(); }

 private:
  double period_ = 0, h_ = 0;
  std::vector<Eigen::MatrixXd> y_, m_;  // values and second derivatives at the nodes
};

struct MonodromyOptions {
  double rtol = 1e-10;   // CVODE relative tolerance
  double atol = 1e-12;   // absolute tolerance on each entry of Phi (Phi(0) = I sets the scale)
  long max_steps = 500000;
};

struct MonodromyResult {
  Eigen::MatrixXd monodromy;  // Phi(T)
  long steps = 0, rhs_evaluations = 0;
};

// Phi(T) of Phi' = A(t) Phi, Phi(0) = I, integrated with CVODE (Adams-Moulton, Newton iteration with a
// dense solver), t in [0, period]. A(t) is n x n; its units fix those of the exponents (1 / unit of t).
MonodromyResult monodromy(const std::function<Eigen::MatrixXd(double)>& A, Eigen::Index n, double period,
                          const MonodromyOptions& options = {});

struct FloquetAnalysis {
  std::string name;                       // e.g. "longitudinal"
  std::vector<std::string> state_order;   // e.g. {"u", "w", "q", "theta"}
  double period_s = 0;
  Eigen::MatrixXd monodromy_si;           // in the dimensional states (m/s, rad/s, rad)
  Eigen::MatrixXd monodromy_nd;           // S M S^-1 with S the non-dimensionalising scaling
  std::vector<std::complex<double>> multipliers;        // mu, sorted by |mu| descending
  std::vector<std::complex<double>> exponents_per_s;    // log(mu) / T
  std::vector<std::complex<double>> exponents_nd;       // times c / U
  std::vector<std::complex<double>> exponents_per_wingbeat;  // log(mu)
  // Modes of the exponent matrix (labels, time scales, eigenvectors in non-dimensional states).
  // Empty with a notice when a multiplier lies on the negative real axis (no real logarithm).
  StabilityAnalysis modes;
  std::vector<std::string> notices;
};

// Multipliers, exponents and labelled modes of a monodromy matrix given in dimensional states.
// nd_scale(i) multiplies state i to make it non-dimensional (1/U for velocities, c/U for rates,
// 1 for angles); reference gives U, c and the frequency. period in seconds.
FloquetAnalysis floquet_analysis(const std::string& name, const std::vector<std::string>& state_order,
                                 const Eigen::MatrixXd& monodromy_si, double period,
                                 const Eigen::VectorXd& nd_scale, const ReferenceQuantities& reference,
                                 const ModeOptions& options = {});

// Non-dimensionalising factor of each named state: u v w -> 1/U, p q r -> c/U, phi theta psi -> 1.
Eigen::VectorXd nondimensional_state_scale(const std::vector<std::string>& state_order,
                                           const ReferenceQuantities& reference);

}  // namespace flapstab
