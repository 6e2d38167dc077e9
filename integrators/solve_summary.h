#pragma once
// What an integrator or a solver reports (style: Ceres' Solver::Summary, docs/development.md): a
// status with its one-line message, the time at which it stopped, and counters. Solvers do not
// throw when they fail numerically; the caller decides (`servokit solve` turns an unusable
// summary into exit 3). It lives with the integrators, which return it, and solvers/ passes it
// on: one status enum with one table of names, so three of its statuses (singular decoupling, not
// applicable, verification failed) are set only by solvers/.
#include <limits>
#include <string>
#include <string_view>

#include "base/vocabulary.h"

namespace servokit {

struct SolveSummary {
  SolveStatus status = SolveStatus::kIntegratorFailure;
  std::string message = "solver was not run";  // one line: why it stopped
  // Where the solver stopped: the end time when converged, else the time of the failure.
  double stop_time = std::numeric_limits<double>::quiet_NaN();
  long steps = 0;                 // accepted steps
  long rejected_steps = 0;        // by the error test or a failed Newton iteration
  long newton_iterations = 0;     // summed over all steps
  long function_evaluations = 0;  // right-hand side or residual evaluations
  long jacobian_evaluations = 0;
  bool IsUsable() const { return status == SolveStatus::kConverged; }
};

}  // namespace servokit
