#pragma once
// Stable inversion (paper Sect. 5.3; Devasia, Chen & Paden 1996; Taylor & Li 2002): the bounded,
// non-causal solution of unstable internal dynamics as a two-sided boundary value problem.
//
// The internal dynamics x' = F(t, x) of the normal form (Eq. 25, x = (z, z')) is solved on a
// window [t_a, t_b] around the motion [t0, tf] with
//   at t_a: the deviation from the start equilibrium lies in its unstable subspace,
//           L_s (x(t_a) - x_start) = 0   (the stable part has not been excited yet);
//   at t_b: the deviation from the end equilibrium lies in its stable subspace,
//           L_u (x(t_b) - x_end) = 0     (the unstable part must have come to rest).
// Outside the window the solution is the linear modes decaying away from it. The window is
// chosen from the eigenvalues so that these modes have decayed to the tolerance, and widened
// until the answer no longer changes.
#include <Eigen/Dense>
#include <functional>
#include <optional>
#include <vector>

#include "integrators/solve_summary.h"
#include "modeling/model.h"
#include "solvers/algebraic_inversion.h"
#include "solvers/motion_extension.h"
#include "trajectories/trajectory.h"

namespace servokit {

struct StableInversionOptions {
  // Relative tolerance of the boundary value problem (estimated error of the collocation
  // solution, BoundaryValueOptions with 7 Lobatto points) and of the window:
  // modes outside the window are below tolerance times their size.
  double tolerance = 1e-8;
  // Absolute level of the collocation's error test (BoundaryValueOptions::absolute_tolerance):
  // components below it count as converged whatever their relative error.
  double absolute_tolerance = 1e-10;
  // Time before the trajectory's first breakpoint and after its last; unset: chosen from the
  // slowest unstable (before) and stable (after) eigenvalue, ln(1/tolerance) / |Re lambda|.
  std::optional<double> pre_actuation, post_actuation;
  // Window widenings (by half each) allowed while the answer still changes by more than the
  // tolerance. 4 reach 1.5^4 = 5 times the first margins, over which the slowest mode decays
  // to tolerance^5: far beyond what the answer can notice, so more would only grow the mesh.
  int max_widenings = 4;
  void Validate() const;
};

/// The window of the boundary value problem and where its input departs from rest.
struct StableInversionWindow {
  double start = 0.0, end = 0.0;
  // First and last time |u_d - u_rest| > tolerance max |u_d - u_rest|, located on the
  // interpolant.
  double pre_actuation_start = 0.0, post_actuation_end = 0.0;
  double boundary_value_residual = 0.0;  // the largest collocation residual
  int widenings = 0;
  std::size_t mesh_points = 0;
};

struct StableInversionSolution {
  SolveSummary summary;
  std::vector<double> times;                 // the final mesh
  std::vector<Eigen::VectorXd> q, q_dot, u;  // at each time
  StableInversionWindow window;
  // q_d, q_d', u_d at any t of the window: the collocation solution's interpolant of the
  // internal state mapped through the servo constraint and Eq. (24), as accurate as the
  // solution itself. Keeps references to the model and the trajectory, which must outlive it.
  std::shared_ptr<const MotionExtension> extension;
};

/// Solves the stable inversion of `model` along `trajectory` (at rest before its first and
/// after its last breakpoint). `start_q`, `end_q`: the equilibria at the start and end of the
/// motion (size dof). Throws NoSolution when an equilibrium's zero dynamics are not
/// hyperbolic (naming the eigenvalues on the imaginary axis) or P is singular there, and
/// UsageError for invalid options.
StableInversionSolution SolveStableInversion(const Model& model,
                                             const OutputTrajectory& trajectory,
                                             const Eigen::VectorXd& start_q,
                                             const Eigen::VectorXd& end_q,
                                             const StableInversionOptions& options = {});

/// Stable inversion of the input-output normal form of any vector relative degree (tangential
/// and mixed realizations): the internal coordinates z = W^T (q, q') of `form` (an
/// AlgebraicInverse with internal dynamics) as the same boundary value problem, their
/// linearization at the rest states taken by central differences of z' = f(t, z) itself.
/// Throws NoSolution when there are no internal dynamics, when the normal form cannot be
/// evaluated at rest or its linearization there is not hyperbolic.
StableInversionSolution SolveOutputStableInversion(const Model& model,
                                                   const OutputTrajectory& trajectory,
                                                   std::shared_ptr<const AlgebraicInverse> form,
                                                   const Eigen::VectorXd& start_q,
                                                   const Eigen::VectorXd& end_q,
                                                   const StableInversionOptions& options = {});

}  // namespace servokit
