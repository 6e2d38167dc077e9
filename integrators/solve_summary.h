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

namespace servokit {

enum class SolveStatus {
  kConverged,           // reached the end time
  kNoConvergence,       // Newton failed even at the smallest step
  kSingularDecoupling,  // P = H M^-1 B became singular along the motion
  kSingularMass,        // M(q) became singular or ill-conditioned
  kStepSizeTooSmall,    // the step size fell below round-off of t
  kTooManySteps,        // the step limit was reached before the end time
  kIntegratorFailure,   // a SUNDIALS integrator failed (its flag is in the message)
  kNotApplicable,       // the method does not fit the problem's class (message says which does)
  kInterrupted,         // the observer asked to stop (e.g. Ctrl-C)
  // The solver reached the end, but its u_d, driving the model, leaves y_d by more than the
  // bound its tolerances allow (solvers/verification.h): the answer is not within them.
  kVerificationFailed,
};

/// The status as a word for JSON ("converged", "singular-decoupling", ...).
std::string_view ToString(SolveStatus status);

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
