#include "solvers/linearly_implicit_dae.h"

#include <cmath>
#include <limits>

namespace servokit {

bool LinearlyImplicitDae::RhsJacobian(double t,
                                      const Eigen::VectorXd& x,
                                      const Eigen::VectorXd& rhs,
                                      Eigen::MatrixXd& jacobian,
                                      std::string& why) {
  // Forward differences: sqrt(eps) balances truncation (~ step) against round-off
  // (~ eps / step); the floor 1e-5 keeps the step meaningful for components near zero.
  const double root_eps = std::sqrt(std::numeric_limits<double>::epsilon());
  const Eigen::Index n = size();
  jacobian.resize(n, n);
  Eigen::VectorXd shifted = x;
  Eigen::MatrixXd mass;
  Eigen::VectorXd shifted_rhs;
  for (Eigen::Index j = 0; j < n; ++j) {
    const double step = root_eps * std::max(std::abs(x(j)), 1e-5);
    shifted(j) = x(j) + step;
    if (!Evaluate(t, shifted, mass, shifted_rhs, why)) return false;
    jacobian.col(j) = (shifted_rhs - rhs) / (shifted(j) - x(j));
    shifted(j) = x(j);
  }
  return true;
}

}  // namespace servokit
