#pragma once
// The input-output normal form of any vector relative degree (Isidori, Nonlinear Control
// Systems, Ch. 4-5) along a desired output: the map from the internal coordinates z = W^T (q, q')
// of an AlgebraicInverse with internal dynamics to q, q' and u, and the internal dynamics
// z' = W^T (q', M^-1 (B u - f)) that the normal form integrates (Dormand-Prince) or solves as a
// boundary value problem (stable inversion).
#include <Eigen/Dense>
#include <memory>
#include <string>

#include "modeling/model.h"
#include "solvers/algebraic_inversion.h"
#include "trajectories/trajectory.h"

namespace servokit {

class OutputNormalFormMap {
 public:
  /// `model`, `trajectory` must outlive the map; q_guess, q_dot_guess start the first Newton
  /// iteration, later ones start from the last state found.
  OutputNormalFormMap(const Model& model,
                      const OutputTrajectory& trajectory,
                      std::shared_ptr<const AlgebraicInverse> form,
                      const Eigen::VectorXd& q_guess,
                      const Eigen::VectorXd& q_dot_guess);

  /// q, q' and u at time t for the internal coordinates `internal`; false with `why` where
  /// Newton fails or a matrix is singular.
  bool State(double t,
             const Eigen::VectorXd& internal,
             Eigen::VectorXd& q,
             Eigen::VectorXd& q_dot,
             Eigen::VectorXd& u,
             std::string& why);

  /// z' at the state State() found last, driven by u.
  bool InternalDerivative(const Eigen::VectorXd& u,
                          Eigen::VectorXd& internal_dot,
                          std::string& why);

  /// z' = f(t, z) in one call (State, then InternalDerivative); u is left as found.
  bool RightHandSide(double t,
                     const Eigen::VectorXd& internal,
                     Eigen::VectorXd& internal_dot,
                     Eigen::VectorXd& u,
                     std::string& why);

  const AlgebraicInverse& form() const { return *form_; }
  /// Whether the last failure was a singular matrix of the input equations.
  bool singular_inputs() const { return inverse_workspace_.singular_inputs(); }

 private:
  const Model& model_;
  const OutputTrajectory& trajectory_;
  std::shared_ptr<const AlgebraicInverse> form_;
  Workspace workspace_;
  AlgebraicInverse::Workspace inverse_workspace_;
  Eigen::LLT<Eigen::MatrixXd> mass_factor_;
  Eigen::MatrixXd derivatives_;
  Eigen::VectorXd q_, q_dot_, velocity_, force_, scratch_q_, scratch_q_dot_;
};

}  // namespace servokit
