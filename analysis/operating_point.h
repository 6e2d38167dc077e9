#pragma once
// The equilibrium at which servokit linearizes (docs/analyze.md "How it is computed", step 1):
// q_dot = 0,  f(q, 0) = B(q) u + C(q)^T lambda,  h(q) = y0,  c(q) = 0 (C^T lambda: a closed
// chain's constraint forces; none for an open chain).
#include <Eigen/Dense>
#include <optional>
#include <string>

#include "modeling/model.h"

namespace servokit {

struct OperatingPointOptions {
  // The output value y0 to hold (size: outputs). Default: the output at the model's start,
  // h(q0) with the model file's `q0:` (Model::operating_point_start), else h(0).
  std::optional<Eigen::VectorXd> y0;
  // Newton's starting point for q (size: dof). Default: the model file's `q0:`, else q = 0.
  std::optional<Eigen::VectorXd> q_guess;
  // Converged when every residual, scaled by the inverse of its Jacobian row's largest entry
  // (so that forces and output coordinates compare in units of q), is below this. 1e-12 leaves
  // a few digits of headroom above double round-off for well-scaled models.
  double residual_tolerance = 1e-12;
  // Newton iterations allowed (KINSOL with line search); equilibria of the shipped models need
  // at most a handful, so 50 only stops a diverging iteration.
  int max_iterations = 50;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate(const Model& model) const;
};

/// An equilibrium: generalized coordinates q (dof), inputs u (inputs) holding it, outputs y.
struct OperatingPoint {
  Eigen::VectorXd q;
  Eigen::VectorXd u;
  Eigen::VectorXd y;
  // Lagrange multipliers lambda (constraints) of a closed chain: C(q)^T lambda are the forces
  // that hold its loops closed (empty for an open chain).
  Eigen::VectorXd multipliers;
  int newton_iterations = 0;  // 0 when the starting point already was an equilibrium
  // Set where the equilibrium is not isolated and the caller named the point (q_guess): a
  // curve of equilibria passes through it (a coordinate the output does not fix, free at
  // rest: the TORA's rotor angle under y = x), and this is its direction in q, unit length.
  // The point is classified where it was named; the direction is a zero at 0.
  std::optional<Eigen::VectorXd> curve_direction;
};

/// "parameters m1 = 1, m2 = 2, ...": the values in workspace.parameters (6 digits), for
/// messages about a point where the model misbehaves.
std::string DescribeParameters(const Model& model, const Workspace& workspace);

/// K = df/dq - sum_k dB/dq_k u_k, dof x dof, into `stiffness`, from df/dq and dB/dq in
/// `workspace` (evaluated at velocity 0): the position block of the equilibrium equations'
/// Jacobian, and the stiffness of the linearization (analysis/linearization.h).
/// `input_force_change` is scratch (dB/dq_k u), the caller's, so that a sweep point, which
/// forms K twice, allocates nothing here (a local vector cost the six-mass chain 8 %).
void EquilibriumStiffness(const Workspace& workspace,
                          const Eigen::Ref<const Eigen::VectorXd>& u,
                          Eigen::Ref<Eigen::MatrixXd> stiffness,
                          Eigen::VectorXd& input_force_change);

/// stiffness -= d(C^T lambda)/dq, the constraint forces' share of the stiffness of a closed
/// chain (column b is (dC/dq_b)^T lambda), from dC/dq in `workspace` (evaluated at q).
void SubtractConstraintStiffness(const Workspace& workspace,
                                 const Eigen::Ref<const Eigen::VectorXd>& multipliers,
                                 Eigen::Ref<Eigen::MatrixXd> stiffness);

/// Finds the equilibrium by Newton's method (SUNDIALS KINSOL) from options.q_guess.
/// Throws UsageError for bad options and NoSolution when Newton does not converge, the
/// equilibrium is not isolated (singular Jacobian) or the model evaluates to NaN or Inf.
/// A closed chain's C must have full row rank there (NoSolution naming the constraint).
/// On return the workspace holds f, B, h, df/dq, df/dq_dot, dB/dq and H (and C, dC/dq) evaluated at
/// (q, 0) of the point found (what Linearize's workspace_holds_jacobians relies on).
OperatingPoint FindOperatingPoint(const Model& model,
                                  Workspace& workspace,
                                  const OperatingPointOptions& options = {});

/// The equilibrium at rest that holds the output at y0, by FindOperatingPoint from q_guess
/// with the default tolerances and a workspace of its own: where a motion from rest to rest
/// starts and ends (the solvers' start, the forward check's rest state).
OperatingPoint FindRestPoint(const Model& model,
                             const Eigen::VectorXd& y0,
                             const Eigen::VectorXd& q_guess);

}  // namespace servokit
