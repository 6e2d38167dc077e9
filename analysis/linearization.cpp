#include "analysis/linearization.h"

#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "analysis/subspaces.h"
#include "base/errors.h"
#include "base/number_format.h"
#include "numerics/finite.h"

namespace servokit {
namespace {

// M counts as singular when its reciprocal condition number (LLT's estimate, 1-norm) is at most
// this: M^-1 then keeps fewer than three correct digits in double precision (relative error
// about epsilon / rcond), so P = H M^-1 B and every rank decision after it would be round-off.
constexpr double kMassMatrixReciprocalConditionLimit = 1e3 * std::numeric_limits<double>::epsilon();

}  // namespace

std::optional<std::string> FindLinearizationProblem(Linearization& linearization) {
  const Eigen::Index dof = linearization.dof();
  const std::pair<const char*, const Eigen::MatrixXd*> quantities[] = {
      {"the mass matrix M", &linearization.mass_matrix},
      {"the damping df/dq_dot", &linearization.damping},
      {"the stiffness df/dq - d(B u0)/dq", &linearization.stiffness},
      {"the input matrix B", &linearization.input_matrix},
      {"the output Jacobian H = dh/dq", &linearization.output_jacobian}};
  for (const auto& [name, matrix] : quantities) {
    if (!AllFinite(*matrix)) {
      return std::string("the linearization at the operating point is not finite: ") + name +
             " holds NaN or Inf";
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> mass_factor(linearization.mass_matrix);
  if (mass_factor.info() != Eigen::Success) {
    return std::string("the mass matrix is not positive definite at the operating point");
  }
  // rcond() divides by the 1-norm of M: when that overflows, the estimate is 0 for a reason
  // that is not singularity.
  const double mass_norm = linearization.mass_matrix.cwiseAbs().colwise().sum().maxCoeff();
  if (!std::isfinite(mass_norm)) {
    return std::string("the mass matrix overflows the range of double at the operating point");
  }
  linearization.mass_inverse.setIdentity(dof, dof);
  mass_factor.solveInPlace(linearization.mass_inverse);
  // LLT's rcond() estimates |M^-1|_1 from below (Hager-Higham: the largest |M^-1 x|_1 it
  // tries, |x|_1 = 1), so its reciprocal condition is at least the exact one, here from the
  // explicit inverse. When the exact one clears the limit with room to spare for rounding, so
  // does the estimate, and the estimate (several triangular solves, a tenth of a sweep point
  // of the six-mass chain) is not needed for the same decision.
  const double inverse_norm = linearization.mass_inverse.cwiseAbs().colwise().sum().maxCoeff();
  const bool clearly_regular =
      std::isfinite(inverse_norm) &&
      1.0 / (mass_norm * inverse_norm) > 2.0 * kMassMatrixReciprocalConditionLimit;
  const double reciprocal_condition = clearly_regular ? 1.0 : mass_factor.rcond();
  if (!(reciprocal_condition > kMassMatrixReciprocalConditionLimit)) {
    return "the mass matrix is singular to working precision at the operating point: "
           "reciprocal condition number " +
           FormatSignificant(reciprocal_condition, 6) +
           " <= " + FormatSignificant(kMassMatrixReciprocalConditionLimit, 6);
  }
  // The analyses read these products (ToStateSpace, P); parameters near the end of the double
  // range (k = 1e308, say) overflow here although every entry above is finite.
  linearization.stiffness_rate.noalias() = linearization.mass_inverse * linearization.stiffness;
  linearization.damping_rate.noalias() = linearization.mass_inverse * linearization.damping;
  linearization.input_acceleration.noalias() =
      linearization.mass_inverse * linearization.input_matrix;
  const std::pair<const char*, const Eigen::MatrixXd*> products[] = {
      {"M^-1", &linearization.mass_inverse},
      {"M^-1 K", &linearization.stiffness_rate},
      {"M^-1 D", &linearization.damping_rate},
      {"M^-1 B", &linearization.input_acceleration}};
  for (const auto& [name, product] : products) {
    if (!AllFinite(*product)) {
      return std::string("the linearization overflows the range of double: ") + name +
             " is not finite at the operating point";
    }
  }
  return std::nullopt;
}

void ProjectOntoTangentSpace(const Eigen::MatrixXd& constraint_jacobian,
                             Linearization& linearization) {
  const Eigen::Index dof = constraint_jacobian.cols();
  const Eigen::Index loops = constraint_jacobian.rows();
  // Q of C^T = Q R: its last dof - loops columns are orthonormal and orthogonal to C's rows.
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(constraint_jacobian.transpose());
  const Eigen::MatrixXd q = qr.householderQ();
  linearization.tangent_basis = q.rightCols(dof - loops);
  const Eigen::MatrixXd& basis = linearization.tangent_basis;
  const auto project = [&basis](Eigen::MatrixXd& matrix) {
    matrix = (basis.transpose() * matrix * basis).eval();
  };
  project(linearization.mass_matrix);
  // M projected is symmetric to rounding; made exactly so for the Cholesky factor.
  linearization.mass_matrix =
      ((linearization.mass_matrix + linearization.mass_matrix.transpose()) / 2).eval();
  project(linearization.damping);
  project(linearization.stiffness);
  linearization.input_matrix = (basis.transpose() * linearization.input_matrix).eval();
  linearization.output_jacobian = (linearization.output_jacobian * basis).eval();
}

Linearization Linearize(const Model& model,
                        Workspace& workspace,
                        const OperatingPoint& point,
                        bool workspace_holds_jacobians) {
  assert(workspace.Fits(model));
  const auto dof = static_cast<Eigen::Index>(model.dof());
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(dof);
  const bool loops = model.num_constraints() > 0;
  unsigned quantities = workspace_holds_jacobians
                            ? static_cast<unsigned>(Quantity::kMassMatrix)
                            : Quantity::kMassMatrix | Quantity::kForcesJacobians |
                                  Quantity::kInputMatrix | Quantity::kInputMatrixDerivatives |
                                  Quantity::kOutputJacobian;
  if (loops && !workspace_holds_jacobians) {
    quantities =
        quantities | Quantity::kConstraintJacobian | Quantity::kConstraintJacobianDerivatives;
  }
  Evaluate(model, workspace, point.q, zero, quantities);
  Linearization linearization;
  linearization.mass_matrix = workspace.mass_matrix;
  linearization.damping = workspace.forces_velocity_jacobian;
  linearization.stiffness.resize(dof, dof);
  Eigen::VectorXd input_force_change;
  EquilibriumStiffness(workspace, point.u, linearization.stiffness, input_force_change);
  linearization.input_matrix = workspace.input_matrix;
  linearization.output_jacobian = workspace.output_jacobian;
  if (loops) {
    SubtractConstraintStiffness(workspace, point.multipliers, linearization.stiffness);
    ProjectOntoTangentSpace(workspace.constraint_jacobian, linearization);
  }

  if (const std::optional<std::string> problem = FindLinearizationProblem(linearization)) {
    throw NoSolution(*problem + " (" + DescribeParameters(model, workspace) + ")");
  }
  return linearization;
}

void ToStateSpace(const Linearization& linearization, StateSpace& state_space) {
  const Eigen::MatrixXd& stiffness_rate = linearization.stiffness_rate;  // 1/s^2
  const Eigen::MatrixXd& damping_rate = linearization.damping_rate;      // 1/s
  // The model's own time scale: sqrt of the stiffness rate, or the damping rate if there is no
  // stiffness, or 1 for a free mass.
  // SafeNorm: norm() squares the entries, which overflows for a stiffness rate above 1e154
  // (k = 1e200 in the mass on car) and made the time scale infinite and B vanish.
  double time_scale = std::sqrt(SafeNorm(stiffness_rate));
  if (!(time_scale > 0.0)) time_scale = SafeNorm(damping_rate);
  if (!(time_scale > 0.0)) time_scale = 1.0;
  ToStateSpace(linearization, time_scale, state_space);
}

void ToStateSpace(const Linearization& linearization, double time_scale, StateSpace& state_space) {
  const Eigen::Index dof = linearization.dof();
  const Eigen::MatrixXd& stiffness_rate = linearization.stiffness_rate;  // 1/s^2
  const Eigen::MatrixXd& damping_rate = linearization.damping_rate;      // 1/s
  state_space.time_scale = time_scale;
  state_space.state_matrix.setZero(2 * dof, 2 * dof);
  state_space.state_matrix.topRightCorner(dof, dof).setIdentity() *= time_scale;
  state_space.state_matrix.bottomLeftCorner(dof, dof) = -stiffness_rate / time_scale;
  state_space.state_matrix.bottomRightCorner(dof, dof) = -damping_rate;
  state_space.input_matrix.setZero(2 * dof, linearization.num_inputs());
  state_space.input_matrix.bottomRows(dof) = linearization.input_acceleration / time_scale;
  state_space.output_matrix.setZero(linearization.output_jacobian.rows(), 2 * dof);
  state_space.output_matrix.leftCols(dof) = linearization.output_jacobian;
}

StateSpace ToStateSpace(const Linearization& linearization) {
  StateSpace state_space;
  ToStateSpace(linearization, state_space);
  return state_space;
}

}  // namespace servokit
