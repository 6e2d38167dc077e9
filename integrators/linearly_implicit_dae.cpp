#include "integrators/linearly_implicit_dae.h"

#include <cmath>
#include <limits>

namespace servokit {

bool LinearlyImplicitDae::RhsJacobian(double t,
                                      const Eigen::VectorXd& x,
                                      const Eigen::VectorXd& rhs,
                                      Eigen::MatrixXd& jacobian,
                                      std::string& why) {
  // Forward differences with RADAU5's step sqrt(eps max(|x_i|, 1e-5)): sqrt(eps) |x_i| balances
  // truncation against round-off where |x_i| is of order one, and near zero the step stays at
  // 4.7e-11, not sqrt(eps) 1e-5 = 1.5e-13, whose round-off (eps |phi| / step ~ 1e-3 |phi|)
  // spoiled Newton's convergence on index-3 components at short steps.
  const double eps = std::numeric_limits<double>::epsilon();
  const Eigen::Index n = size();
  jacobian.resize(n, n);
  Eigen::VectorXd shifted = x;
  Eigen::MatrixXd mass;
  Eigen::VectorXd shifted_rhs;
  for (Eigen::Index j = 0; j < n; ++j) {
    const double step = std::sqrt(eps * std::max(std::abs(x(j)), 1e-5));
    shifted(j) = x(j) + step;
    if (!Evaluate(t, shifted, mass, shifted_rhs, why)) return false;
    jacobian.col(j) = (shifted_rhs - rhs) / (shifted(j) - x(j));
    shifted(j) = x(j);
  }
  return true;
}

}  // namespace servokit
