#include "solvers/internal_dynamics.h"

#include <cmath>
#include <limits>
#include <string>

#include "base/errors.h"
#include "solvers/servo_constraint_problem.h"

namespace servokit {
namespace {

// A trajectory that answers chosen values of y_d, y_d', y_d'' at every t: the drive Y as an
// independent variable of the normal form.
class FixedOutputTrajectory final : public OutputTrajectory {
 public:
  explicit FixedOutputTrajectory(Eigen::MatrixXd derivatives)
      : derivatives_(std::move(derivatives)) {}
  Eigen::VectorXd Derivative(double, int order) const override {
    if (order < derivatives_.cols()) return derivatives_.col(order);
    return Eigen::VectorXd::Zero(derivatives_.rows());
  }
  Eigen::Index outputs() const override { return derivatives_.rows(); }
  int continuous_derivatives() const override { return 1 << 20; }
  std::vector<double> breakpoints() const override { return {}; }
  Eigen::MatrixXd& derivatives() { return derivatives_; }

 private:
  Eigen::MatrixXd derivatives_;
};

// Central differences: error ~ h^2 f''' against round-off ~ eps / h, balanced at eps^(1/3).
double DifferenceStep(double value) {
  return std::cbrt(std::numeric_limits<double>::epsilon()) * std::max(1.0, std::abs(value));
}

}  // namespace

LinearInternalDynamics LinearizeInternalDynamics(const Model& model,
                                                 const Eigen::VectorXd& q,
                                                 const Eigen::VectorXd& chart_q) {
  const auto dof = Eigen::Index(model.dof());
  const auto outputs = Eigen::Index(model.num_outputs());
  if (q.size() != dof) {
    throw UsageError("LinearizeInternalDynamics: q has " + std::to_string(q.size()) +
                     " entries, the model " + std::to_string(dof) + " coordinates");
  }
  Workspace workspace(model);
  Evaluate(model, workspace, q, Eigen::VectorXd::Zero(dof), Quantity::kOutput);
  FixedOutputTrajectory trajectory(Eigen::MatrixXd::Zero(outputs, 3));
  trajectory.derivatives().col(0) = workspace.output;
  ServoConstraintProblem problem(model, trajectory, chart_q.size() == 0 ? q : chart_q);
  const Eigen::Index internal = problem.num_internal();
  const Eigen::MatrixXd& directions = problem.internal_directions();

  LinearInternalDynamics result;
  result.internal_directions = directions;
  result.equilibrium_state = Eigen::VectorXd::Zero(2 * internal);
  result.equilibrium_state.head(internal) = directions.transpose() * q;
  result.equilibrium_output = Eigen::VectorXd::Zero(3 * outputs);
  result.equilibrium_output.head(outputs) = workspace.output;

  // F(x, Y) = (x', u) of the normal form at state x and drive Y.
  Eigen::VectorXd q_guess = q;
  // The problem caches y_d per time; the fixed trajectory ignores t, so each evaluation gets a
  // time of its own and sees the drive just set.
  double time = 0.0;
  auto normal_form = [&](const Eigen::VectorXd& state, const Eigen::VectorXd& drive,
                         Eigen::VectorXd& state_rate, Eigen::VectorXd& input) {
    for (int order = 0; order < 3; ++order) {
      trajectory.derivatives().col(order) = drive.segment(order * outputs, outputs);
    }
    Eigen::VectorXd coordinates = q_guess, velocities, accelerations;
    std::string why;
    time += 1.0;
    if (!problem.StateFromInternal(time, state.head(internal), state.tail(internal), coordinates,
                                   velocities, why) ||
        !problem.NormalForm(time, coordinates, velocities, input, accelerations, why)) {
      throw NoSolution("no normal form at the equilibrium: " + why);
    }
    state_rate.resize(2 * internal);
    state_rate << state.tail(internal), directions.transpose() * accelerations;
  };
  Eigen::VectorXd rate;
  normal_form(result.equilibrium_state, result.equilibrium_output, rate, result.equilibrium_input);

  const Eigen::Index inputs = result.equilibrium_input.size();
  result.state_matrix.resize(2 * internal, 2 * internal);
  result.input_state.resize(inputs, 2 * internal);
  result.drive_matrix.resize(2 * internal, 3 * outputs);
  result.input_drive.resize(inputs, 3 * outputs);
  Eigen::VectorXd rate_plus, rate_minus, input_plus, input_minus;
  for (Eigen::Index j = 0; j < 2 * internal; ++j) {
    const double step = DifferenceStep(result.equilibrium_state(j));
    Eigen::VectorXd shifted = result.equilibrium_state;
    shifted(j) += step;
    normal_form(shifted, result.equilibrium_output, rate_plus, input_plus);
    shifted(j) -= 2 * step;
    normal_form(shifted, result.equilibrium_output, rate_minus, input_minus);
    result.state_matrix.col(j) = (rate_plus - rate_minus) / (2 * step);
    result.input_state.col(j) = (input_plus - input_minus) / (2 * step);
  }
  for (Eigen::Index j = 0; j < 3 * outputs; ++j) {
    const double step = DifferenceStep(result.equilibrium_output(j));
    Eigen::VectorXd shifted = result.equilibrium_output;
    shifted(j) += step;
    normal_form(result.equilibrium_state, shifted, rate_plus, input_plus);
    shifted(j) -= 2 * step;
    normal_form(result.equilibrium_state, shifted, rate_minus, input_minus);
    result.drive_matrix.col(j) = (rate_plus - rate_minus) / (2 * step);
    result.input_drive.col(j) = (input_plus - input_minus) / (2 * step);
  }
  return result;
}

}  // namespace servokit
