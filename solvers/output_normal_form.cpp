#include "solvers/output_normal_form.h"

#include <utility>

namespace servokit {

OutputNormalFormMap::OutputNormalFormMap(const Model& model,
                                         const OutputTrajectory& trajectory,
                                         std::shared_ptr<const AlgebraicInverse> form,
                                         const Eigen::VectorXd& q_guess,
                                         const Eigen::VectorXd& q_dot_guess)
    : model_(model),
      trajectory_(trajectory),
      form_(std::move(form)),
      workspace_(model),
      q_(q_guess),
      q_dot_(q_dot_guess) {}

bool OutputNormalFormMap::State(double t,
                                const Eigen::VectorXd& internal,
                                Eigen::VectorXd& q,
                                Eigen::VectorXd& q_dot,
                                Eigen::VectorXd& u,
                                std::string& why) {
  trajectory_.Derivatives(t, form_->highest_output_derivative(), derivatives_);
  if (!form_->EvaluateWithInternal(derivatives_, internal, model_.parameters(), q_, q_dot_, u, why,
                                   inverse_workspace_)) {
    return false;
  }
  q = q_;
  q_dot = q_dot_;
  return true;
}

bool OutputNormalFormMap::InternalDerivative(const Eigen::VectorXd& u,
                                             Eigen::VectorXd& internal_dot,
                                             std::string& why) {
  Evaluate(model_, workspace_, q_, q_dot_,
           Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix);
  mass_factor_.compute(workspace_.mass_matrix);
  if (mass_factor_.info() != Eigen::Success) {
    why = "M(q) is not positive definite";
    return false;
  }
  const Eigen::Index f = q_.size();
  velocity_.resize(2 * f);
  velocity_.head(f) = q_dot_;
  force_.noalias() = workspace_.input_matrix * u;
  force_ -= workspace_.forces;
  velocity_.tail(f) = force_;
  mass_factor_.solveInPlace(velocity_.tail(f));
  internal_dot.noalias() = form_->internal_directions().transpose() * velocity_;
  return true;
}

bool OutputNormalFormMap::RightHandSide(double t,
                                        const Eigen::VectorXd& internal,
                                        Eigen::VectorXd& internal_dot,
                                        Eigen::VectorXd& u,
                                        std::string& why) {
  return State(t, internal, scratch_q_, scratch_q_dot_, u, why) &&
         InternalDerivative(u, internal_dot, why);
}

}  // namespace servokit
