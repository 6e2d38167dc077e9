#pragma once
// The inverse model of a closed kinematic chain,  M q'' + f = B u + C^T lambda,  c(q) = 0,
// h(q) = y_d  (paper Eqs. 6-9): solved as the open chain whose servo constraints are both sets,
// [h; c] = [y_d; 0], with [u; lambda] as its inputs (LoopsAsServoConstraints, modeling/model.h).
// Every method of this folder then applies as it is: the projected DAE projects onto the
// complement of both constraint sets (Blajer), the normal form's internal coordinates number
// dof - constraints - outputs, and stable inversion, the algebraic inverse and the linearized
// inverse see the loop's forces C^T lambda as inputs they solve for. The answer is split back
// into u_d and the multipliers lambda_d along the motion.
#include <Eigen/Dense>
#include <cstddef>
#include <memory>
#include <vector>

#include "analysis/classification.h"
#include "modeling/model.h"
#include "solvers/feedforward_solution.h"
#include "trajectories/trajectory.h"

namespace servokit {

/// y_d followed by `constraints` zeros: the desired values of [h; c]. Keeps a reference to
/// `trajectory`, which must outlive it.
class LoopTargets final : public OutputTrajectory {
 public:
  LoopTargets(const OutputTrajectory& trajectory, std::size_t constraints)
      : trajectory_(trajectory), constraints_(Eigen::Index(constraints)) {}
  Eigen::VectorXd Derivative(double t, int order) const override;
  void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const override;
  Eigen::Index outputs() const override { return trajectory_.outputs() + constraints_; }
  int continuous_derivatives() const override { return trajectory_.continuous_derivatives(); }
  std::vector<double> breakpoints() const override { return trajectory_.breakpoints(); }

 private:
  const OutputTrajectory& trajectory_;
  Eigen::Index constraints_;
  mutable Eigen::MatrixXd outputs_;  // Derivatives() of y_d alone, then copied into place
};

/// A closed chain as the open chain it is solved as, with the classification the solvers read.
struct LoopsAsServoProblem {
  std::shared_ptr<const Model> model;                  // LoopsAsServoConstraints(loop model)
  std::shared_ptr<const OutputTrajectory> trajectory;  // LoopTargets: [y_d; 0]
  // `model` classified at the loop model's operating point, with its rank tolerance: the
  // inputs [u; lambda] hold it there, and its zero dynamics are the loop model's (the same
  // bordered pencil), so the method chosen for it fits the closed chain.
  Classification classification;
};

/// The open-chain form of `model` (with constraints) for `trajectory` at `classification`'s
/// operating point (the loop model's Classify()). `trajectory` must outlive the result.
LoopsAsServoProblem MakeLoopsAsServoProblem(const Model& model,
                                            const OutputTrajectory& trajectory,
                                            const Classification& classification);

/// Splits the inputs [u; lambda] of `solution` (solved for `problem`) into u (the first
/// `inputs`) and FeedforwardSolution::multipliers, in its rows and in its continuous extension,
/// which keeps `problem`'s model and trajectory alive.
void SplitMultipliers(const LoopsAsServoProblem& problem,
                      std::size_t inputs,
                      FeedforwardSolution& solution);

}  // namespace servokit
