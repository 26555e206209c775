// Initial-value problems with CVODES: x' = f(t, x) with forward sensitivities to chosen initial states.
#pragma once
#include <functional>
#include <vector>
#include <Eigen/Dense>

namespace flapstab {

using OdeRhs = std::function<void(double t, const Eigen::VectorXd& x, Eigen::VectorXd& dxdt)>;
// df/dx (n x n) at (t, x).
using OdeJacobian = std::function<void(double t, const Eigen::VectorXd& x, Eigen::MatrixXd& dfdx)>;

struct OdeOptions {
  double rtol = 1e-12;
  Eigen::VectorXd scale;  // typical magnitude of each state: atol_i = rtol * scale_i (empty: all 1)
  long max_steps = 1000000;
  // Optional exact df/dx: with it the sensitivity right-hand sides are (df/dx) s_j, one Jacobian per (t, x) shared
  // by all directions and corrector iterations, and the Newton iteration's matrix uses it too. Empty: differences.
  OdeJacobian jacobian;
};

struct OdeSolution {
  Eigen::VectorXd x;                     // x(t1)
  Eigen::MatrixXd sensitivity;           // d x(t1) / d x(t0)_j for j in sensitivity_states (n x k)
  std::vector<Eigen::VectorXd> samples;  // x at the requested sample times
  long steps = 0, rhs_evaluations = 0;
};

// Integrates from t0 to t1 with CVODES (Adams-Moulton, Newton iteration, dense direct solver). With
// sensitivity_states non-empty, the forward sensitivity equations s_j' = (df/dx) s_j, s_j(t0) = e_j
// are solved alongside (staggered corrector, error-controlled), with (df/dx) s_j from options.jacobian
// when given, else from central directional differences of f (step 5e-6 of the state scales). sample_times: ascending, in [t0, t1].
// Throws SolveError when CVODES fails.
OdeSolution integrate_ode(const OdeRhs& f, const Eigen::VectorXd& x0, double t0, double t1,
                          const std::vector<int>& sensitivity_states = {},
                          const std::vector<double>& sample_times = {}, const OdeOptions& options = {});

}  // namespace flapstab
