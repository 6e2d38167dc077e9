#pragma once
// The model driven forward by a given input: the plant of the forward check
// (solvers/verification.h), and of anyone who simulates a feedforward:
//   M(q) q'' + f(q, q') = B(q) u(t),
// and for a closed chain  M q'' + f = B u + C^T lambda, c(q) = 0, integrated in its index-1 form
// (C q'' + C' q' = 0, lambda from the Schur complement C M^-1 C^T) with the state projected back
// onto c(q) = 0 and C q' = 0 after every step (the coordinate projection method, Hairer &
// Wanner, Solving ODEs II, Sect. VII.2), so that the loops stay closed to round-off.
#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "integrators/solve_summary.h"
#include "integrators/sundials_integrators.h"
#include "modeling/model.h"

namespace servokit {

class ForwardModel {
 public:
  /// Keeps a reference to `model`, which must outlive it. Not thread-safe (one workspace).
  explicit ForwardModel(const Model& model) : model_(model), workspace_(model) {}

  Eigen::Index dof() const { return Eigen::Index(model_.dof()); }
  bool closed_chain() const { return model_.num_constraints() > 0; }

  /// q'' at (q, q') under u; false with `why` where M (or C M^-1 C^T) is singular.
  bool Acceleration(const Eigen::VectorXd& q,
                    const Eigen::VectorXd& q_dot,
                    const Eigen::VectorXd& u,
                    Eigen::VectorXd& q_ddot,
                    std::string& why);

  /// The correction that puts y = (q, q') back onto c(q) = 0 and C(q) q' = 0, each by the
  /// orthogonal projection (Gauss-Newton steps -C^T (C C^T)^-1 c for q), and the local error
  /// estimate, when given, projected onto the tangent space at the corrected q. A closed chain
  /// only. False with `why` where the loops cannot be closed from y.
  bool Project(const Eigen::VectorXd& y,
               Eigen::VectorXd& correction,
               Eigen::VectorXd* error,
               std::string& why);

  /// max |c(q)|: how well a state keeps the loops closed. A closed chain only.
  double ConstraintViolation(const Eigen::VectorXd& q);

  /// h(q).
  Eigen::VectorXd Output(const Eigen::VectorXd& q);

  /// The largest real part of the eigenvalues of d(q', q'')/d(q, q') at (q, q', u): how fast
  /// nearby motions move apart there (central differences; on the loops' tangent space for a
  /// closed chain; NaN where M is singular).
  double GrowthRate(const Eigen::VectorXd& q,
                    const Eigen::VectorXd& q_dot,
                    const Eigen::VectorXd& u);

 private:
  const Model& model_;
  Workspace workspace_;
  Eigen::LLT<Eigen::MatrixXd> mass_factor_;
  Eigen::MatrixXd constraint_accelerations_;  // M^-1 C^T
  Eigen::LLT<Eigen::MatrixXd> schur_factor_;  // C M^-1 C^T
  Eigen::LLT<Eigen::MatrixXd> gram_factor_;   // C C^T
};

/// u(t): false with `why` where it cannot be given.
using ForwardInput = std::function<bool(double t, Eigen::VectorXd& u, std::string& why)>;

/// Integrates `model` under `input` from `state` = (q, q') at t_start to t_end with CVODE's BDF
/// (projected onto the loops for a closed chain, whose start must be on them), stopping on the
/// breakpoints, with the observer at every step, and CVODE's interpolant of every step in
/// `dense_output` when given. As IntegrateBdf, it reports a failure in the summary and does not
/// throw for it.
SolveSummary SimulateForward(ForwardModel& model,
                             const ForwardInput& input,
                             double t_start,
                             const Eigen::VectorXd& state,
                             double t_end,
                             const std::vector<double>& breakpoints,
                             const IntegratorOptions& options,
                             const IntegratorObserver& observer,
                             DenseOutput* dense_output = nullptr);

}  // namespace servokit
