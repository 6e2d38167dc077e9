#include "analysis/linearization.h"

#include <cassert>
#include <cmath>

#include "models/errors.h"

namespace servokit {

Linearization Linearize(const Model& model, Workspace& workspace, const OperatingPoint& point) {
  assert(workspace.Fits(model));
  const auto dof = static_cast<Eigen::Index>(model.dof());
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(dof);
  Evaluate(model, workspace, point.q, zero,
           Quantity::kMassMatrix | Quantity::kForcesJacobians | Quantity::kInputMatrix |
               Quantity::kInputMatrixDerivatives | Quantity::kOutputJacobian);
  Linearization linearization;
  linearization.mass_matrix = workspace.mass_matrix;
  linearization.damping = workspace.forces_velocity_jacobian;
  linearization.stiffness = workspace.forces_position_jacobian;
  for (Eigen::Index k = 0; k < dof; ++k) {
    linearization.stiffness.col(k) -= workspace.input_matrix_derivatives[std::size_t(k)] * point.u;
  }
  linearization.input_matrix = workspace.input_matrix;
  linearization.output_jacobian = workspace.output_jacobian;

  if (!linearization.mass_matrix.allFinite() || !linearization.damping.allFinite() ||
      !linearization.stiffness.allFinite() || !linearization.input_matrix.allFinite() ||
      !linearization.output_jacobian.allFinite()) {
    throw NoSolution(
        "the linearization at the operating point is not finite (NaN or Inf in M, "
        "f, B or H): check the parameters");
  }
  const Eigen::LLT<Eigen::MatrixXd> mass_factor(linearization.mass_matrix);
  if (mass_factor.info() != Eigen::Success) {
    throw NoSolution("the mass matrix is not positive definite at the operating point");
  }
  linearization.mass_inverse = mass_factor.solve(Eigen::MatrixXd::Identity(dof, dof));
  return linearization;
}

StateSpace ToStateSpace(const Linearization& linearization) {
  const Eigen::Index dof = linearization.dof();
  const Eigen::MatrixXd& mass_inverse = linearization.mass_inverse;
  const Eigen::MatrixXd stiffness_rate = mass_inverse * linearization.stiffness;  // 1/s^2
  const Eigen::MatrixXd damping_rate = mass_inverse * linearization.damping;      // 1/s
  // The model's own time scale: sqrt of the stiffness rate, or the damping rate if there is no
  // stiffness, or 1 for a free mass.
  double time_scale = std::sqrt(stiffness_rate.norm());
  if (!(time_scale > 0.0)) time_scale = damping_rate.norm();
  if (!(time_scale > 0.0)) time_scale = 1.0;

  StateSpace state_space;
  state_space.time_scale = time_scale;
  state_space.state_matrix = Eigen::MatrixXd::Zero(2 * dof, 2 * dof);
  state_space.state_matrix.topRightCorner(dof, dof).setIdentity() *= time_scale;
  state_space.state_matrix.bottomLeftCorner(dof, dof) = -stiffness_rate / time_scale;
  state_space.state_matrix.bottomRightCorner(dof, dof) = -damping_rate;
  state_space.input_matrix = Eigen::MatrixXd::Zero(2 * dof, linearization.num_inputs());
  state_space.input_matrix.bottomRows(dof) = mass_inverse * linearization.input_matrix / time_scale;
  state_space.output_matrix = Eigen::MatrixXd::Zero(linearization.output_jacobian.rows(), 2 * dof);
  state_space.output_matrix.leftCols(dof) = linearization.output_jacobian;
  return state_space;
}

}  // namespace servokit
