#include "solvers/linearized_inverse.h"

#include <memory>
#include <string>
#include <utility>

#include "solvers/motion_extension.h"

namespace servokit {
namespace {

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

}  // namespace

Model LinearizedModel(const Model& model, const Classification& classification) {
  const Linearization& linear = classification.linearization;
  LinearEquations equations;
  equations.name = model.name() + "_linearized";
  equations.description = model.name() + " linearized at its operating point (deviations)";
  equations.source = model.source() + " (linearized)";
  equations.coordinates = model.coordinates();
  equations.inputs = model.inputs();
  equations.mass_matrix = linear.mass_matrix;
  equations.stiffness = linear.stiffness;
  equations.damping = linear.damping;
  equations.input_matrix = linear.input_matrix;
  equations.output_jacobian = linear.output_jacobian;
  return ModelFromLinearEquations(equations);
}

std::shared_ptr<DeviationProblem> MakeDeviationProblem(const Model& model,
                                                       const OutputTrajectory& trajectory,
                                                       const Classification& classification) {
  Model linearized = LinearizedModel(model, classification);
  Workspace workspace(linearized);
  Classification linear_class = Classify(linearized, workspace);
  return std::make_shared<DeviationProblem>(DeviationProblem{
      std::move(linearized), std::move(linear_class),
      std::make_unique<ShiftedTrajectory>(trajectory, classification.operating_point.y)});
}

void ShiftToOperatingPoint(std::shared_ptr<const DeviationProblem> deviation,
                           const Classification& classification,
                           FeedforwardSolution& solution) {
  const Eigen::VectorXd& q0 = classification.operating_point.q;
  const Eigen::VectorXd& u0 = classification.operating_point.u;
  for (std::size_t i = 0; i < solution.times.size(); ++i) {
    solution.q[i] += q0;
    solution.u[i] += u0;
  }
  if (solution.extension) {
    solution.extension =
        std::make_shared<const ShiftedMotion>(std::move(deviation), solution.extension, q0, u0);
  }
  solution.method_reason =
      "asked for: the exact inverse of the linearization at the operating "
      "point (" +
      std::string(ToString(solution.method)) + "), applied to the nonlinear model";
  solution.method = SolverMethod::kLinearized;
  solution.warnings.push_back(
      "linearized: u_d inverts the linearization at the operating point, not the model; "
      "the forward check measures how far the model's output strays from y_d");
}

}  // namespace servokit
