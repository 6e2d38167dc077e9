#pragma once
// A DAE in linearly implicit form,  A(t, x) x' = phi(t, x),  with A possibly singular: the shape
// of the projected servo-constraint equations (paper Eqs. 15-18, summarized as Eqs. 57-60),
// and what Radau IIA and Euler backward (integrators/radau.h) integrate.
#include <Eigen/Dense>
#include <string>
#include <vector>

namespace servokit {

class LinearlyImplicitDae {
 public:
  virtual ~LinearlyImplicitDae() = default;

  /// Number of unknowns n.
  virtual Eigen::Index size() const = 0;

  /// Differentiation index of each component (1, 2 or 3), size n. The error estimate of an
  /// index-k component is scaled by h^(k-1) (Hairer & Wanner, Sect. VII.8), since its local
  /// error is of lower order and would otherwise force needlessly small steps.
  virtual std::vector<int> ComponentIndices() const = 0;

  /// A(t, x) (n x n) and phi(t, x) (n) at (t, x). Returns false and sets `why` (one line,
  /// e.g. "M(q) is singular") when they cannot be evaluated there; the integrator then reduces
  /// the step or stops with that reason.
  virtual bool Evaluate(double t,
                        const Eigen::VectorXd& x,
                        Eigen::MatrixXd& mass,
                        Eigen::VectorXd& rhs,
                        std::string& why) = 0;

  /// d phi / dx at (t, x) (n x n), where `rhs` = phi(t, x) is already known. The default uses
  /// forward differences with RADAU5's steps sqrt(eps max(|x_i|, 1e-5)).
  virtual bool RhsJacobian(double t,
                           const Eigen::VectorXd& x,
                           const Eigen::VectorXd& rhs,
                           Eigen::MatrixXd& jacobian,
                           std::string& why);
};

}  // namespace servokit
