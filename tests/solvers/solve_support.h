#pragma once
// What the solver tests share: a model loaded and classified, a solve that must run, and u_d
// from a solution's continuous extension.
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "analysis/classification.h"
#include "solvers/inverse_model.h"

namespace servokit::testing {

struct ClassifiedModel {
  Model model;
  Classification classification;
};

inline ClassifiedModel LoadClassified(const std::string& path,
                                      const std::vector<ParameterOverride>& set = {}) {
  ClassifiedModel problem{LoadModel(path, set), {}};
  Workspace workspace(problem.model);
  problem.classification = Classify(problem.model, workspace);
  return problem;
}

/// SolveInverseModel with `method` over [trajectory start, t_end]; REQUIREs a usable answer.
inline FeedforwardSolution SolveUsable(const ClassifiedModel& problem,
                                       const OutputTrajectory& trajectory,
                                       SolverMethod method,
                                       double t_end,
                                       InverseModelOptions options = {}) {
  options.method = method;
  options.t_end = t_end;
  FeedforwardSolution solution =
      SolveInverseModel(problem.model, trajectory, problem.classification, options);
  INFO(ToString(method) << ": " << solution.summary.message);
  REQUIRE(solution.summary.IsUsable());
  return solution;
}

/// u_d at t from the solution's continuous extension; REQUIREs that it evaluates.
inline Eigen::VectorXd InputAt(const FeedforwardSolution& solution, double t) {
  Eigen::VectorXd q, q_dot, u;
  std::string why;
  REQUIRE(solution.extension->Evaluate(t, q, q_dot, u, why));
  return u;
}

}  // namespace servokit::testing
