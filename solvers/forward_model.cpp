#include "solvers/forward_model.h"

#include <cmath>
#include <string>
#include <vector>

#include "base/number_format.h"

namespace servokit {
namespace {

constexpr unsigned kForwardDynamics =
    Quantity::kMassMatrix | Quantity::kForces | Quantity::kInputMatrix;
// Central differences of the forward dynamics: step relative to 1 + |x_j| (about eps^(1/3)).
constexpr double kDifferenceStep = 1e-5;

// Newton's method that puts a closed chain's q back on c(q) = 0 stops when its correction is
// below this relative to 1 + |q| (a few ulps), or after kMaxProjectionIterations.
constexpr double kProjectionTolerance = 1e-15;
constexpr int kMaxProjectionIterations = 10;
// What the projection may leave of |c(q)|, relative to 1 + |q|, and still count as on it.
constexpr double kProjectionResidualTolerance = 1e-12;

}  // namespace

bool ForwardModel::Acceleration(const Eigen::VectorXd& q,
                                const Eigen::VectorXd& q_dot,
                                const Eigen::VectorXd& u,
                                Eigen::VectorXd& q_ddot,
                                std::string& why) {
  Evaluate(model_, workspace_, q, q_dot,
           closed_chain()
               ? kForwardDynamics | Quantity::kConstraintJacobian | Quantity::kConstraintBias
               : kForwardDynamics);
  mass_factor_.compute(workspace_.mass_matrix);
  if (mass_factor_.info() != Eigen::Success) {
    why = "M(q) is not positive definite";
    return false;
  }
  q_ddot = mass_factor_.solve(workspace_.input_matrix * u - workspace_.forces);
  if (!closed_chain()) return true;
  // lambda from C q'' + c_bar = 0 with q'' = M^-1 (B u - f + C^T lambda): the Schur
  // complement C M^-1 C^T, positive definite while the constraints are independent.
  const Eigen::MatrixXd& jacobian = workspace_.constraint_jacobian;
  constraint_accelerations_ = mass_factor_.solve(jacobian.transpose());  // M^-1 C^T
  schur_factor_.compute(jacobian * constraint_accelerations_);
  if (schur_factor_.info() != Eigen::Success) {
    why = "the loop constraints are dependent at q (C M^-1 C^T is singular)";
    return false;
  }
  const Eigen::VectorXd multipliers =
      schur_factor_.solve(-(jacobian * q_ddot + workspace_.constraint_bias));
  q_ddot += constraint_accelerations_ * multipliers;
  return true;
}

bool ForwardModel::Project(const Eigen::VectorXd& y,
                           Eigen::VectorXd& correction,
                           Eigen::VectorXd* error,
                           std::string& why) {
  const Eigen::Index f = dof();
  Eigen::VectorXd q = y.head(f);
  for (int iteration = 0;; ++iteration) {
    Evaluate(model_, workspace_, q, Eigen::VectorXd::Zero(f),
             Quantity::kConstraints | Quantity::kConstraintJacobian);
    const Eigen::MatrixXd& jacobian = workspace_.constraint_jacobian;
    gram_factor_.compute(jacobian * jacobian.transpose());
    if (gram_factor_.info() != Eigen::Success) {
      why = "the loop constraints are dependent at q (C C^T is singular)";
      return false;
    }
    const Eigen::VectorXd step = -jacobian.transpose() * gram_factor_.solve(workspace_.constraints);
    q += step;
    if (step.lpNorm<Eigen::Infinity>() <=
        kProjectionTolerance * (1.0 + q.lpNorm<Eigen::Infinity>())) {
      break;
    }
    if (iteration + 1 == kMaxProjectionIterations) {
      if (workspace_.constraints.lpNorm<Eigen::Infinity>() <=
          kProjectionResidualTolerance * (1.0 + q.lpNorm<Eigen::Infinity>())) {
        break;
      }
      why = "the loops cannot be closed again: |c(q)| = " +
            FormatSignificant(workspace_.constraints.lpNorm<Eigen::Infinity>(), 6) + " after " +
            std::to_string(kMaxProjectionIterations) + " Newton steps";
      return false;
    }
  }
  Evaluate(model_, workspace_, q, Eigen::VectorXd::Zero(f), Quantity::kConstraintJacobian);
  const Eigen::MatrixXd& jacobian = workspace_.constraint_jacobian;
  gram_factor_.compute(jacobian * jacobian.transpose());
  const auto onto_tangent_space = [&](const Eigen::VectorXd& vector) -> Eigen::VectorXd {
    return vector - jacobian.transpose() * gram_factor_.solve(jacobian * vector);
  };
  correction.resize(2 * f);
  correction.head(f) = q - y.head(f);
  correction.tail(f) = onto_tangent_space(y.tail(f)) - y.tail(f);
  if (error != nullptr) {
    error->head(f) = onto_tangent_space(error->head(f));
    error->tail(f) = onto_tangent_space(error->tail(f));
  }
  return true;
}

double ForwardModel::ConstraintViolation(const Eigen::VectorXd& q) {
  Evaluate(model_, workspace_, q, Eigen::VectorXd::Zero(q.size()), Quantity::kConstraints);
  return workspace_.constraints.lpNorm<Eigen::Infinity>();
}

Eigen::VectorXd ForwardModel::Output(const Eigen::VectorXd& q) {
  Evaluate(model_, workspace_, q, Eigen::VectorXd::Zero(q.size()), Quantity::kOutput);
  return workspace_.output;
}

double ForwardModel::GrowthRate(const Eigen::VectorXd& q,
                                const Eigen::VectorXd& q_dot,
                                const Eigen::VectorXd& u) {
  const Eigen::Index f = q.size();
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(2 * f, 2 * f);
  jacobian.topRightCorner(f, f).setIdentity();
  Eigen::VectorXd state(2 * f), plus, minus;
  state << q, q_dot;
  std::string why;
  for (Eigen::Index j = 0; j < 2 * f; ++j) {
    const double step = kDifferenceStep * (1.0 + std::abs(state(j)));
    Eigen::VectorXd shifted = state;
    shifted(j) += step;
    if (!Acceleration(shifted.head(f), shifted.tail(f), u, plus, why)) return NAN;
    shifted(j) = state(j) - step;
    if (!Acceleration(shifted.head(f), shifted.tail(f), u, minus, why)) return NAN;
    jacobian.block(f, j, f, 1) = (plus - minus) / (2.0 * step);
  }
  if (!jacobian.allFinite()) return NAN;
  if (closed_chain()) {
    // Only motions along the loops count: off c(q) = 0 the index-1 form drifts polynomially
    // (c'' = 0), a double zero that round-off may push to either side. Restricted to the
    // tangent space (T, orthonormal, spans the null space of C), as the projection holds it.
    Evaluate(model_, workspace_, q, q_dot, Quantity::kConstraintJacobian);
    const Eigen::MatrixXd tangent =
        Eigen::FullPivLU<Eigen::MatrixXd>(workspace_.constraint_jacobian).kernel();
    const Eigen::MatrixXd basis = Eigen::HouseholderQR<Eigen::MatrixXd>(tangent).householderQ() *
                                  Eigen::MatrixXd::Identity(f, tangent.cols());
    Eigen::MatrixXd states = Eigen::MatrixXd::Zero(2 * f, 2 * basis.cols());
    states.topLeftCorner(f, basis.cols()) = basis;
    states.bottomRightCorner(f, basis.cols()) = basis;
    jacobian = states.transpose() * jacobian * states;
  }
  return Eigen::EigenSolver<Eigen::MatrixXd>(jacobian, false).eigenvalues().real().maxCoeff();
}

SolveSummary SimulateForward(ForwardModel& model,
                             const ForwardInput& input,
                             double t_start,
                             const Eigen::VectorXd& state,
                             double t_end,
                             const std::vector<double>& breakpoints,
                             const IntegratorOptions& options,
                             const IntegratorObserver& observer,
                             DenseOutput* dense_output) {
  const Eigen::Index f = model.dof();
  Eigen::VectorXd u, q_ddot;
  // Without loops the projection is empty and CVODE runs as IntegrateBdf.
  const OdeProjection projection =
      model.closed_chain()
          ? OdeProjection([&](double, const Eigen::VectorXd& y, Eigen::VectorXd& correction,
                              Eigen::VectorXd* error, std::string& why) {
              return model.Project(y, correction, error, why);
            })
          : OdeProjection();
  return IntegrateProjectedBdf(
      [&](double t, const Eigen::VectorXd& y, Eigen::VectorXd& y_dot, std::string& why) {
        if (!input(t, u, why) || !model.Acceleration(y.head(f), y.tail(f), u, q_ddot, why)) {
          return false;
        }
        y_dot.resize(2 * f);
        y_dot << y.tail(f), q_ddot;
        return true;
      },
      projection, t_start, state, t_end, breakpoints, options, observer, dense_output);
}

}  // namespace servokit
