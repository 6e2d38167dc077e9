#pragma once
// How servokit uses GSL: statuses checked by the caller, never GSL's abort-on-error handler,
// and one loop around GSL's bracketing root solvers.
#include <gsl/gsl_roots.h>

#include <functional>
#include <optional>

namespace servokit {

/// Turns GSL's abort-on-error handler off, once per process (thread-safe).
void UseGslStatusCodes();

/// The final bracket of a root and the solver's estimate inside it.
struct RootBracket {
  double lower = 0.0;
  double upper = 0.0;
  double root = 0.0;
  bool converged = false;  // the bracket reached the requested relative width
};

/// Narrows [lower, upper], across which `function` changes sign, with GSL's bracketing solver
/// `type`: gsl_root_fsolver_bisection for a step function (a class that changes), Brent for a
/// smooth one. Stops when gsl_root_test_interval(lower, upper, absolute_tolerance,
/// relative_tolerance) holds, the bracket no longer shrinks, or an iteration fails. With an
/// absolute_tolerance of 0 a root at 0 is narrowed to the smallest doubles; give one (e.g. the
/// relative tolerance itself: a width relative to max(1, |root|)) where that precision is not
/// meant. Returns nullopt when GSL rejects the bracket (no sign change, or not finite at an end).
std::optional<RootBracket> NarrowBracket(const gsl_root_fsolver_type* type,
                                         const std::function<double(double)>& function,
                                         double lower,
                                         double upper,
                                         double relative_tolerance,
                                         double absolute_tolerance = 0.0);

}  // namespace servokit
