#pragma once
// What a solve of the inverse model answers (solvers/inverse_model.h): the feedforward u_d, the
// motion q_d and how they were found. In a header of its own so that the methods the dispatcher
// puts together (solvers/linearized_inverse.h) fill it in without including the dispatcher.
#include <Eigen/Dense>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "integrators/solve_summary.h"
#include "solvers/motion_extension.h"
#include "solvers/solve_settings.h"
#include "solvers/stable_inversion.h"

namespace servokit {

/// What the verification's bound is derived from: how accurate the method was asked to be.
struct SolveAccuracy {
  double rtol = std::numeric_limits<double>::quiet_NaN();  // NaN: exact (algebraic inverse)
  double atol = std::numeric_limits<double>::quiet_NaN();
  std::optional<double> step;  // Euler backward: first order in its fixed step
};

/// The answer.
struct FeedforwardSolution {
  SolverMethod method = SolverMethod::kAuto;  // the method that ran (never kAuto)
  std::string method_reason;                  // why that method (auto's choice, or "asked for")
  SolveSummary summary;
  double t_start = 0.0, t_end = 0.0;  // the span solved (defaults resolved)
  SolveAccuracy accuracy;
  // Rows: the method's own points (always including t_start and, when it got there, t_end),
  // or t_start + k sample_time when sample_time is set; up to where the solve stopped.
  std::optional<double> sample_time;
  std::vector<double> times;
  std::vector<Eigen::VectorXd> q, q_dot, u;  // one per time: dof, dof, inputs
  // A closed chain's multipliers lambda_d (one per time: constraints): C^T lambda_d are the
  // forces that keep its loops closed along the motion. Empty for an open chain.
  std::vector<Eigen::VectorXd> multipliers;
  // max |h(q) - y_d| over the rows; for a closed chain max |[h(q) - y_d; c(q)]|, its loops too.
  double max_servo_residual = std::numeric_limits<double>::quiet_NaN();
  std::optional<StableInversionWindow> window;  // stable inversion only
  // Things a user should know that do not stop the solve (the window cut short, ...).
  std::vector<std::string> warnings;
  // q_d, q_d' and u_d at any time of [t_start, where the solve stopped]: the method's own
  // continuous extension. Null when the solve stopped before its first step.
  std::shared_ptr<const MotionExtension> extension;
};

}  // namespace servokit
