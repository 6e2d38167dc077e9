#include "solvers/linearized_inverse.h"

#include <cstdio>
#include <memory>
#include <string>
#include <utility>

#include "solvers/motion_extension.h"

namespace servokit {
namespace {

// A number as the model file reads it back exactly (17 significant digits).
std::string Exact(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

// sum_j matrix(i, j) names[j] (+ the velocities' terms), "0" when all vanish.
std::string LinearCombination(const Eigen::RowVectorXd& row,
                              const std::vector<std::string>& names,
                              const std::string& suffix) {
  std::string text;
  for (Eigen::Index j = 0; j < row.size(); ++j) {
    if (row[j] == 0.0) continue;
    text += (text.empty() ? "" : " + ") + std::string("(") + Exact(row[j]) + ")*" +
            names[static_cast<std::size_t>(j)] + suffix;
  }
  return text;
}

std::string MatrixRows(const Eigen::MatrixXd& matrix) {
  std::string text;
  for (Eigen::Index i = 0; i < matrix.rows(); ++i) {
    text += "  - [";
    for (Eigen::Index j = 0; j < matrix.cols(); ++j) {
      text += (j ? ", " : "") + Exact(matrix(i, j));
    }
    text += "]\n";
  }
  return text;
}

// y_d - y0: the desired output of the deviation model.
class ShiftedTrajectory final : public OutputTrajectory {
 public:
  ShiftedTrajectory(const OutputTrajectory& trajectory, Eigen::VectorXd offset)
      : trajectory_(trajectory), offset_(std::move(offset)) {}
  Eigen::VectorXd Derivative(double t, int order) const override {
    Eigen::VectorXd value = trajectory_.Derivative(t, order);
    if (order == 0) value -= offset_;
    return value;
  }
  void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const override {
    trajectory_.Derivatives(t, highest, derivatives);
    derivatives.col(0) -= offset_;
  }
  Eigen::Index outputs() const override { return trajectory_.outputs(); }
  int continuous_derivatives() const override { return trajectory_.continuous_derivatives(); }
  std::vector<double> breakpoints() const override { return trajectory_.breakpoints(); }

 private:
  const OutputTrajectory& trajectory_;
  Eigen::VectorXd offset_;
};

// What the deviation solution's extension refers to, kept alive with it.
struct DeviationProblem {
  Model model;
  std::unique_ptr<ShiftedTrajectory> trajectory;
};

// The deviation solution's motion shifted back by (q0, u0).
class ShiftedMotion final : public MotionExtension {
 public:
  ShiftedMotion(std::shared_ptr<const DeviationProblem> problem,
                std::shared_ptr<const MotionExtension> inner,
                Eigen::VectorXd q0,
                Eigen::VectorXd u0)
      : MotionExtension(inner->start(), inner->end()),
        problem_(std::move(problem)),
        inner_(std::move(inner)),
        q0_(std::move(q0)),
        u0_(std::move(u0)) {}
  bool Evaluate(double t,
                Eigen::VectorXd& q,
                Eigen::VectorXd& q_dot,
                Eigen::VectorXd& u,
                std::string& why) const override {
    if (!inner_->Evaluate(t, q, q_dot, u, why)) return false;
    q += q0_;
    u += u0_;
    return true;
  }

 private:
  std::shared_ptr<const DeviationProblem> problem_;
  std::shared_ptr<const MotionExtension> inner_;
  Eigen::VectorXd q0_, u0_;
};

// `text` as a double-quoted YAML scalar: the model's name is free text (quotes, colons, '#').
std::string YamlString(const std::string& text) {
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      quoted += '\\';
      quoted += c;
    } else if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
      quoted += ' ';  // refused in names at load; never a line break in this text
    } else {
      quoted += c;
    }
  }
  return quoted + "\"";
}

}  // namespace

Model LinearizedModel(const Model& model, const Classification& classification) {
  const Linearization& linear = classification.linearization;
  const std::vector<std::string>& coordinates = model.coordinates();
  std::string text = "name: " + YamlString(model.name() + "_linearized") + "\n";
  text += "description: " +
          YamlString(model.name() + " linearized at its operating point (deviations)") + "\n";
  text += "parameters: {}\ncoordinates: [";
  for (std::size_t j = 0; j < coordinates.size(); ++j) text += (j ? ", " : "") + coordinates[j];
  text += "]\ninputs: [";
  for (std::size_t k = 0; k < model.inputs().size(); ++k) {
    text += (k ? ", " : "") + model.inputs()[k];
  }
  text += "]\nmass_matrix:\n" + MatrixRows(linear.mass_matrix) + "forces:\n";
  for (Eigen::Index i = 0; i < linear.dof(); ++i) {
    std::string force = LinearCombination(linear.stiffness.row(i), coordinates, "");
    const std::string damping = LinearCombination(linear.damping.row(i), coordinates, "_dot");
    if (!damping.empty()) force += (force.empty() ? "" : " + ") + damping;
    text += "  - " + (force.empty() ? std::string("0") : force) + "\n";
  }
  text += "input_matrix:\n" + MatrixRows(linear.input_matrix) + "outputs:\n";
  for (Eigen::Index i = 0; i < linear.output_jacobian.rows(); ++i) {
    const std::string output = LinearCombination(linear.output_jacobian.row(i), coordinates, "");
    text += "  - " + (output.empty() ? std::string("0") : output) + "\n";
  }
  return LoadModelFromString(text, model.source() + " (linearized)");
}

FeedforwardSolution SolveLinearizedInverse(const Model& model,
                                           const OutputTrajectory& trajectory,
                                           const Classification& classification,
                                           const InverseModelOptions& options) {
  auto deviation = std::make_shared<DeviationProblem>(
      DeviationProblem{LinearizedModel(model, classification), nullptr});
  deviation->trajectory =
      std::make_unique<ShiftedTrajectory>(trajectory, classification.operating_point.y);
  Workspace workspace(deviation->model);
  const Classification linear_class = Classify(deviation->model, workspace);
  InverseModelOptions linear_options = options;
  // Exact inverses of the linearization: algebraic when flat, else the bounded (stable
  // inversion) one; critical zero dynamics have no bounded inverse, the normal form serves.
  linear_options.method = linear_class.flat ? SolverMethod::kAlgebraic
                          : linear_class.zero_dynamics.stability == Stability::kCritical
                              ? SolverMethod::kNormalForm
                              : SolverMethod::kStableInversion;
  FeedforwardSolution solution =
      SolveInverseModel(deviation->model, *deviation->trajectory, linear_class, linear_options);
  const Eigen::VectorXd& q0 = classification.operating_point.q;
  const Eigen::VectorXd& u0 = classification.operating_point.u;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    solution.q[i] += q0;
    solution.u[i] += u0;
  }
  if (solution.extension) {
    solution.extension = std::make_shared<const ShiftedMotion>(
        std::shared_ptr<const DeviationProblem>(std::move(deviation)), solution.extension, q0, u0);
  }
  solution.method_reason =
      "asked for: the exact inverse of the linearization at the operating "
      "point (" +
      std::string(ToString(solution.method)) + "), applied to the nonlinear model";
  solution.method = SolverMethod::kLinearized;
  solution.warnings.push_back(
      "linearized: u_d inverts the linearization at the operating point, not the model; "
      "the forward check measures how far the model's output strays from y_d");
  return solution;
}

}  // namespace servokit
