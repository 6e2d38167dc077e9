#include "solvers/closed_chain.h"

#include <string>
#include <utility>

#include "analysis/options.h"

namespace servokit {
namespace {

// The extension of the open-chain form, read as the closed chain's: u without the multipliers.
// Owns what the inner extension refers to (the open-chain model and [y_d; 0]).
class WithoutMultipliers final : public MotionExtension {
 public:
  WithoutMultipliers(std::shared_ptr<const MotionExtension> inner,
                     std::shared_ptr<const Model> model,
                     std::shared_ptr<const OutputTrajectory> trajectory,
                     Eigen::Index inputs)
      : MotionExtension(inner->start(), inner->end()),
        inner_(std::move(inner)),
        model_(std::move(model)),
        trajectory_(std::move(trajectory)),
        inputs_(inputs) {}

  bool Evaluate(double t,
                Eigen::VectorXd& q,
                Eigen::VectorXd& q_dot,
                Eigen::VectorXd& u,
                std::string& why) const override {
    if (!inner_->Evaluate(t, q, q_dot, inputs_and_multipliers_, why)) return false;
    u = inputs_and_multipliers_.head(inputs_);
    return true;
  }

 private:
  std::shared_ptr<const MotionExtension> inner_;
  std::shared_ptr<const Model> model_;
  std::shared_ptr<const OutputTrajectory> trajectory_;
  Eigen::Index inputs_;
  mutable Eigen::VectorXd inputs_and_multipliers_;  // not thread-safe, as MotionExtension
};

}  // namespace

Eigen::VectorXd LoopTargets::Derivative(double t, int order) const {
  Eigen::VectorXd value = Eigen::VectorXd::Zero(outputs());
  value.head(trajectory_.outputs()) = trajectory_.Derivative(t, order);
  return value;
}

void LoopTargets::Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const {
  trajectory_.Derivatives(t, highest, outputs_);
  derivatives.setZero(outputs(), highest + 1);
  derivatives.topRows(trajectory_.outputs()) = outputs_;
}

LoopsAsServoProblem MakeLoopsAsServoProblem(const Model& model,
                                            const OutputTrajectory& trajectory,
                                            const Classification& classification) {
  LoopsAsServoProblem problem;
  problem.model = std::make_shared<const Model>(LoopsAsServoConstraints(model));
  problem.trajectory = std::make_shared<const LoopTargets>(trajectory, model.num_constraints());
  ClassificationOptions options;
  Eigen::VectorXd held(problem.model->num_outputs());
  held << classification.operating_point.y,
      Eigen::VectorXd::Zero(Eigen::Index(model.num_constraints()));
  options.operating_point.y0 = held;
  options.operating_point.q_guess = classification.operating_point.q;
  options.rank_tolerance = classification.rank_tolerance;
  options.cross_check = false;  // the loop model's own classification was cross-checked
  Workspace workspace(*problem.model);
  problem.classification = Classify(*problem.model, workspace, options);
  return problem;
}

void SplitMultipliers(const LoopsAsServoProblem& problem,
                      std::size_t inputs,
                      FeedforwardSolution& solution) {
  const auto count = Eigen::Index(inputs);
  solution.multipliers.clear();
  for (Eigen::VectorXd& row : solution.u) {
    solution.multipliers.push_back(row.tail(row.size() - count));
    row.conservativeResize(count);
  }
  if (solution.extension) {
    solution.extension = std::make_shared<const WithoutMultipliers>(
        std::move(solution.extension), problem.model, problem.trajectory, count);
  }
}

}  // namespace servokit
