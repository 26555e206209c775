// Newton's method on a residual r(z) with its Jacobian: least squares / minimum norm steps for a non-square system,
// halved until |r| decreases. Shared by the shooting trims (trim/cyclic.hpp, trim/translation.hpp).
#pragma once
#include <functional>
#include <string>
#include <Eigen/Dense>

namespace flapstab {

// r(z); with jacobian != nullptr also d r / d z.
using ResidualFunction = std::function<Eigen::VectorXd(const Eigen::VectorXd& z, Eigen::MatrixXd* jacobian)>;

struct NewtonOutcome {
  Eigen::VectorXd z, r;   // the last iterate and its residual
  int iterations = 0;
  bool converged = false; // max |r| <= tolerance
  std::string message;    // why not, when not
};

NewtonOutcome newton_solve(const ResidualFunction& residual, Eigen::VectorXd z, double tolerance, int max_iterations);

}  // namespace flapstab
