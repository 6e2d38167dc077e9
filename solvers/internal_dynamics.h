#pragma once
// The internal dynamics of the normal form (paper Eq. 25) linearized about an equilibrium, with
// the desired output as its drive:
//   x' = A (x - x0) + G (Y - Y0),   u = u0 + U_x (x - x0) + U_Y (Y - Y0),
// x = (z, z') the internal state (z = C^T q, Eq. 19), Y = (y_d, y_d', y_d'') stacked by order.
// The linear model behind stable inversion (Devasia et al. 1996) and its boundary conditions;
// obtained by central differences of the servo-constraint problem's own normal form, so it is
// the linearization of exactly what the nonlinear solvers integrate.
#include <Eigen/Dense>

#include "modeling/model.h"

namespace servokit {

struct LinearInternalDynamics {
  Eigen::VectorXd equilibrium_state;    // x0, size 2 (dof - outputs)
  Eigen::VectorXd equilibrium_output;   // Y0, size 3 outputs
  Eigen::VectorXd equilibrium_input;    // u0, size inputs
  Eigen::MatrixXd state_matrix;         // A
  Eigen::MatrixXd drive_matrix;         // G
  Eigen::MatrixXd input_state;          // U_x
  Eigen::MatrixXd input_drive;          // U_Y
  Eigen::MatrixXd internal_directions;  // C, dof x (dof - outputs), as the normal form uses it
};

/// Linearizes the normal form at the equilibrium q (size dof, at rest, h(q) = y), with the
/// internal coordinates z = C^T q chosen at `chart_q` (ServoConstraintProblem's reference point;
/// empty: q itself). Stable inversion linearizes at both ends of a motion in the chart of its
/// start, the one its boundary value problem integrates in, so that the two ends' conditions
/// speak of the same coordinates even where C = D_0 turns with H(q). Throws NoSolution when P
/// is singular there (no normal form) or the chart does not reach q, and UsageError for wrong
/// sizes.
LinearInternalDynamics LinearizeInternalDynamics(const Model& model,
                                                 const Eigen::VectorXd& q,
                                                 const Eigen::VectorXd& chart_q = {});

}  // namespace servokit
