#pragma once
// The Jacobian linearization of M(q) q'' + f(q, q') = B(q) u, y = h(q) at an equilibrium:
//   M dq'' + damping dq' + stiffness dq = B du,   dy = H dq,
// with stiffness = df/dq - d(B u0)/dq and damping = df/dq' (M'(q) q'' vanishes at rest); for
// a closed chain, stiffness also - d(C^T lambda0)/dq, and everything on the constraints'
// tangent space (Linearization::tangent_basis).
#include <Eigen/Dense>
#include <optional>
#include <string>

#include "analysis/operating_point.h"
#include "modeling/model.h"

namespace servokit {

struct Linearization {
  Eigen::MatrixXd mass_matrix;      // M(q0), dof x dof, symmetric positive definite
  Eigen::MatrixXd damping;          // df/dq_dot at (q0, 0), dof x dof
  Eigen::MatrixXd stiffness;        // df/dq - sum_k dB/dq_k u0, dof x dof
  Eigen::MatrixXd input_matrix;     // B(q0), dof x inputs
  Eigen::MatrixXd output_jacobian;  // H(q0), outputs x dof (Eq. 4)
  // M^-1, from its Cholesky factor, computed once: the dense analyses are small (a few dozen
  // coordinates at most), where one inverse is cheaper than repeated blocked solves.
  Eigen::MatrixXd mass_inverse;
  // M^-1 K (1/s^2), M^-1 D (1/s) and M^-1 B: formed once, here, where their overflow is checked;
  // the state space and P = H M^-1 B read them. (ReducedLinearization, which has no K and D,
  // fills input_acceleration alone.)
  Eigen::MatrixXd stiffness_rate;
  Eigen::MatrixXd damping_rate;
  Eigen::MatrixXd input_acceleration;
  // A closed chain's: an orthonormal basis T (model dof x dof - constraints) of the tangent
  // space of c(q) = 0 at q0, C T = 0. Its motions are dq = T dz, and every matrix above is in
  // z: T^T M T, T^T D T, T^T K T (K with the constraint forces' share, d(C^T lambda0)/dq),
  // T^T B and H T, which is M dq'' + D dq' + K dq = B du + C^T dlambda, C dq = 0 with the
  // multipliers eliminated (premultiplied by T^T, T^T C^T = 0). Empty for an open chain.
  Eigen::MatrixXd tangent_basis;

  Eigen::Index dof() const { return mass_matrix.rows(); }
  Eigen::Index num_inputs() const { return input_matrix.cols(); }
};

/// The checks of a linearization, in one place: every matrix finite; M symmetric positive
/// definite, of finite norm and not singular to working precision (reciprocal condition number
/// above 1e3 epsilon); M^-1, M^-1 K, M^-1 D and M^-1 B finite. Reads mass_matrix, damping,
/// stiffness, input_matrix and output_jacobian and fills mass_inverse, stiffness_rate,
/// damping_rate and input_acceleration. Returns the first problem found, one line naming the
/// quantity (without the parameter values), or nullopt. Linearize throws it as NoSolution; a
/// sweep's polynomial path (analysis/sweep_point.cpp) runs the same checks, so that a sweep
/// point fails exactly where `analyze` does.
std::optional<std::string> FindLinearizationProblem(Linearization& linearization);

/// Projects the matrices of `linearization` (full coordinates) onto the tangent space of the
/// constraints, whose Jacobian at the point is `constraint_jacobian` (full row rank), and keeps
/// the basis (Linearization::tangent_basis).
void ProjectOntoTangentSpace(const Eigen::MatrixXd& constraint_jacobian,
                             Linearization& linearization);

/// Linearizes `model` at `point`. Throws NoSolution with FindLinearizationProblem's message and
/// the parameter values if the linearization fails its checks.
/// With `workspace_holds_jacobians`, the caller vouches that the workspace holds df/dq,
/// df/dq_dot, B, dB/dq and H evaluated at (point.q, 0) as FindOperatingPoint leaves them, and
/// only M is evaluated (Classify: a sweep point does not evaluate the Jacobians twice).
Linearization Linearize(const Model& model,
                        Workspace& workspace,
                        const OperatingPoint& point,
                        bool workspace_holds_jacobians = false);

/// The first-order form x = [dq; dq' / time_scale] of a linearization:
/// x' = state_matrix x + input_matrix du, dy = output_matrix x. Scaling the velocities by the
/// model's own time scale balances the blocks (positions ~ 1, accelerations ~ omega^2), so that
/// rank decisions compare like with like; it is a similarity transform and changes no zero,
/// no pole and no Markov parameter.
struct StateSpace {
  Eigen::MatrixXd state_matrix;   // 2 dof x 2 dof
  Eigen::MatrixXd input_matrix;   // 2 dof x inputs
  Eigen::MatrixXd output_matrix;  // outputs x 2 dof
  double time_scale = 1.0;        // velocities are divided by this (1/s)
};
StateSpace ToStateSpace(const Linearization& linearization);
/// The same into `state_space`, whose matrices keep their memory when their sizes do not change.
void ToStateSpace(const Linearization& linearization, StateSpace& state_space);
/// The same with the given time scale: 1 gives the unscaled form x = (dq, dq'), A = [0 I; -M^-1 K
/// -M^-1 D], B = [0; M^-1 B], C = [H 0] (the API's state-space model, api::LinearizeAt).
void ToStateSpace(const Linearization& linearization, double time_scale, StateSpace& state_space);

}  // namespace servokit
