#pragma once
// The servo-constraint problem along a desired trajectory,  M(q) q'' + f(q, q') = B(q) u,
// h(q) = y_d(t)  (paper Eqs. 8-9), in the forms the solvers of this folder integrate, written
// once here:
//   - the projected DAE (Eqs. 15-18) in x = (q, v, u) as A(t, x) x' = phi(t, x), for Radau IIA
//     and Euler backward (ProjectedDae);
//   - its index-1 form for IDA (IndexOneResidual): the internal parts C^T q' = C^T v and
//     C^T v' = C^T M^-1 (B u - f) of Eq. (15), with the servo constraint at position,
//     velocity (H v = y_d') and acceleration level (Eq. 17) for the rest. Its leading term
//     C^T x' has a constant null space, which BDF needs to be stable on it;
//   - the normal form (Eqs. 19-25): internal coordinates z = C^T q (C selects the unactuated
//     coordinates q_u, as Eq. 19 does, when B acts on single coordinates and H_a is invertible;
//     otherwise C = D at the reference point), u from Eq. (24) and z'' from Eq. (25).
//
// D(q), the tangent basis of Eq. (11), is D(q) = (I - H^T (H H^T)^-1 H) D_0 with D_0 the
// orthonormal tangent basis at the reference point: smooth in q (an SVD basis computed anew at
// every q may flip sign or rotate between steps), and H D = 0 holds exactly.
#include <Eigen/Dense>
#include <limits>
#include <string>
#include <vector>

#include "integrators/linearly_implicit_dae.h"
#include "integrators/solve_summary.h"
#include "modeling/model.h"
#include "trajectories/trajectory.h"

namespace servokit {

struct ServoProblemOptions {
  // M(q) counts as singular when the reciprocal of its condition number (LLT estimate) falls
  // below this: beyond it, M^-1 loses all digits a double has.
  double min_mass_reciprocal_condition = 1e-13;
  // P counts as singular when sigma_min(P) <= rank_tolerance |H| |M^-1 B|: the same relative
  // rule as ClassificationOptions::rank_tolerance, so that a solve stops where the analysis
  // would call P rank-deficient.
  double rank_tolerance = 1e-10;
  // Newton's method that recovers q from (y_d, z) stops when the correction is below this,
  // relative to 1 + |q|.
  double coordinate_tolerance = 1e-13;
  int max_coordinate_iterations = 25;
  // When H (and M, B) do not depend on q, factor them once instead of at every evaluation.
  // Off only to check the general path against the shortcut.
  bool exploit_constant_structure = true;
  // Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

class ServoConstraintProblem {
 public:
  /// `reference_q` (size dof) is where D_0 and the internal directions C are chosen: the
  /// operating point. Keeps references to `model` and `trajectory`, which must outlive it.
  /// Throws NoSolution when H has rank < outputs at reference_q, UsageError for bad options or
  /// a trajectory with another number of outputs than the model.
  ServoConstraintProblem(const Model& model,
                         const OutputTrajectory& trajectory,
                         const Eigen::VectorXd& reference_q,
                         const ServoProblemOptions& options = {});

  const Model& model() const { return model_; }
  const OutputTrajectory& trajectory() const { return trajectory_; }
  Eigen::Index dof() const { return Eigen::Index(model_.dof()); }
  Eigen::Index num_inputs() const { return Eigen::Index(model_.num_inputs()); }
  Eigen::Index num_outputs() const { return Eigen::Index(model_.num_outputs()); }
  /// f - m: the number of internal coordinates.
  Eigen::Index num_internal() const { return internal_directions_.cols(); }

  /// C (dof x (dof - m)): z = C^T q are the internal coordinates of the normal form.
  const Eigen::MatrixXd& internal_directions() const { return internal_directions_; }
  /// True when C selects the unactuated coordinates q_u (the paper's Eq. 19).
  bool internal_are_unactuated() const { return internal_are_unactuated_; }

  /// The state on the servo constraint with internal state (z, z') at t: Newton on
  /// h(q) = y_d(t), C^T q = z (Eq. 19) from the q passed in, then q' from Eq. (20).
  bool StateFromInternal(double t,
                         const Eigen::Ref<const Eigen::VectorXd>& z,
                         const Eigen::Ref<const Eigen::VectorXd>& z_dot,
                         Eigen::VectorXd& q,
                         Eigen::VectorXd& q_dot,
                         std::string& why);

  /// u from Eq. (24) and q'' = M^-1 (B u - f) (whose C^T-part is Eq. 25) at (t, q, q').
  /// Fails with a reason when M or P is singular there.
  bool NormalForm(double t,
                  const Eigen::VectorXd& q,
                  const Eigen::VectorXd& q_dot,
                  Eigen::VectorXd& u,
                  Eigen::VectorXd& q_ddot,
                  std::string& why);

  /// Eqs. (15)-(18) at (t, x = (q, v, u)): A (n x n) and phi (n), n = 2 dof + inputs.
  bool ProjectedEquations(double t,
                          const Eigen::VectorXd& x,
                          Eigen::MatrixXd& mass,
                          Eigen::VectorXd& rhs,
                          std::string& why);

  /// The index-1 residual of the projected DAE at (t, x, x'), size 2 dof + inputs:
  /// C^T (q' - v), h(q) - y_d, C^T (v' - M^-1 (B u - f)), H v - y_d',
  /// P u - H M^-1 f + h_bar - y_d''.
  bool IndexOneResidual(double t,
                        const Eigen::VectorXd& x,
                        const Eigen::VectorXd& x_dot,
                        Eigen::VectorXd& residual,
                        std::string& why);

  /// max_i |h_i(q) - y_d,i(t)|: how well a solution keeps the servo constraint (Eq. 18).
  double ServoResidual(double t, const Eigen::VectorXd& q);

  /// D(q) of Eq. (11), dof x (dof - m), continuous along the motion (see the file comment).
  Eigen::MatrixXd TangentBasisAt(const Eigen::MatrixXd& output_jacobian) const;

  /// det P at the last successful NormalForm(). Its sign change between two steps means P
  /// was singular in between, even where an integrator stepped over the singular instant.
  double decoupling_determinant() const { return decoupling_determinant_; }

  /// What made the last failed evaluation fail: kSingularDecoupling (P), kSingularMass (M),
  /// kNoConvergence (q from y_d and z) or kIntegratorFailure (NaN or Inf). Lets a solver that
  /// stopped report the kind of singularity, with the reason in its message.
  SolveStatus last_failure() const { return last_failure_; }

 private:
  // M, f, B, H, h_bar, h at (q, q_dot) into workspace_, and M's Cholesky factor; false with a
  // reason when M is singular or a value is not finite.
  bool EvaluateDynamics(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& q_dot,
                        std::string& why,
                        bool with_output = true);

  // NormalForm() when M, B and H are constant: only f is evaluated.
  bool ConstantGeometryNormalForm(double t,
                                  const Eigen::VectorXd& q,
                                  const Eigen::VectorXd& q_dot,
                                  Eigen::VectorXd& u,
                                  Eigen::VectorXd& q_ddot,
                                  std::string& why);

  // y_d, y_d', y_d'' at t into desired_ (outputs x 3); the normal form asks twice per t.
  void DesiredAt(double t) {
    if (t == desired_time_) return;
    trajectory_.Derivatives(t, 2, desired_);
    desired_time_ = t;
  }

  const Model& model_;
  const OutputTrajectory& trajectory_;
  ServoProblemOptions options_;
  Workspace workspace_;
  Eigen::LLT<Eigen::MatrixXd> mass_factor_;
  // Buffers of the right-hand sides, kept so that an integrator's inner loop allocates little.
  Eigen::VectorXd zero_velocity_;
  Eigen::MatrixXd desired_;
  double desired_time_ = std::numeric_limits<double>::quiet_NaN();
  Eigen::MatrixXd chart_;  // [H; C^T]
  Eigen::VectorXd chart_residual_, correction_, velocity_targets_;
  Eigen::PartialPivLU<Eigen::MatrixXd> chart_factor_;
  Eigen::MatrixXd accelerations_of_inputs_and_forces_;  // M^-1 [B f], one solve for both
  Eigen::VectorXd force_accelerations_;                 // M^-1 f
  Eigen::MatrixXd decoupling_;                          // P
  Eigen::FullPivLU<Eigen::MatrixXd> decoupling_factor_;
  Eigen::VectorXd decoupling_rhs_;           // H M^-1 f - h_bar + y_d'' (Eq. 24)
  Eigen::MatrixXd tangent_basis_;            // D(q) of the last evaluation
  Eigen::VectorXd applied_;                  // B u - f
  Eigen::VectorXd accelerations_;            // M^-1 (B u - f)
  Eigen::MatrixXd reference_tangent_basis_;  // D_0
  Eigen::MatrixXd internal_directions_;      // C
  bool internal_are_unactuated_ = false;
  SolveStatus last_failure_ = SolveStatus::kConverged;
  double decoupling_determinant_ = std::numeric_limits<double>::quiet_NaN();
  double constant_decoupling_determinant_ = std::numeric_limits<double>::quiet_NaN();
  // h is linear in q (H constant, as for the mass on car): [H; C^T] is factored once and
  // StateFromInternal() needs no Newton iteration.
  bool output_is_linear_ = false;
  Eigen::MatrixXd constant_chart_inverse_;  // [H; C^T]^-1: a product is cheaper than a solve
  Eigen::VectorXd output_offset_;           // h_0 = h(q) - H q
  // M, B and H do not depend on q (linear and linearized models, the mass on car): M is
  // factored, M^-1 B and P are formed once, and the normal form evaluates only f.
  bool constant_geometry_ = false;
  Eigen::LLT<Eigen::MatrixXd> constant_mass_factor_;
  Eigen::MatrixXd constant_input_accelerations_;  // M^-1 B
  Eigen::MatrixXd constant_decoupling_inverse_;   // P^-1
};

/// The projected DAE (Eqs. 15-18) as Radau IIA and Euler backward see it. Component indices:
/// q 1, v 2 (its H-part is fixed by the derivative of Eq. 18), u 2 when P is regular at the
/// reference point (Eq. 17 gives u from q and v) and 3 otherwise (as the multipliers of
/// index-3 mechanical systems).
class ProjectedDae final : public LinearlyImplicitDae {
 public:
  ProjectedDae(ServoConstraintProblem& problem, bool decoupling_regular)
      : problem_(problem), decoupling_regular_(decoupling_regular) {}
  Eigen::Index size() const override { return 2 * problem_.dof() + problem_.num_inputs(); }
  std::vector<int> ComponentIndices() const override;
  bool Evaluate(double t,
                const Eigen::VectorXd& x,
                Eigen::MatrixXd& mass,
                Eigen::VectorXd& rhs,
                std::string& why) override {
    return problem_.ProjectedEquations(t, x, mass, rhs, why);
  }

 private:
  ServoConstraintProblem& problem_;
  bool decoupling_regular_;
};

}  // namespace servokit
