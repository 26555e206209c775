// Damped Newton iteration for the shooting trims.
#include "trim/newton.hpp"

#include <fmt/format.h>

namespace flapstab {

NewtonOutcome newton_solve(const ResidualFunction& residual, Eigen::VectorXd z, double tolerance, int max_iterations) {
  NewtonOutcome o;
  Eigen::MatrixXd J;
  Eigen::VectorXd r = residual(z, &J);
  for (o.iterations = 0; o.iterations < max_iterations; ++o.iterations) {
    if (r.cwiseAbs().maxCoeff() <= tolerance) {
      o.converged = true;
      break;
    }
    // Newton step (least squares / minimum norm when not square), halved until |r| decreases.
    const Eigen::VectorXd dz = -J.completeOrthogonalDecomposition().solve(r);
    double alpha = 1;
    Eigen::VectorXd z_new, r_new;
    for (int k = 0; k < 12; ++k, alpha /= 2) {
      z_new = z + alpha * dz;
      r_new = residual(z_new, nullptr);
      if (r_new.norm() < r.norm()) break;
    }
    if (!(r_new.norm() < r.norm())) {
      o.message = "line search failed to reduce the periodicity residual";
      break;
    }
    z = z_new;
    r = r_new.cwiseAbs().maxCoeff() <= tolerance ? r_new : residual(z, &J);
  }
  if (!o.converged && r.cwiseAbs().maxCoeff() <= tolerance) o.converged = true;
  if (!o.converged && o.message.empty()) o.message = fmt::format("no convergence in {} Newton iterations", max_iterations);
  o.z = z;
  o.r = r;
  return o;
}

}  // namespace flapstab
