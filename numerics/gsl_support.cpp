#include "numerics/gsl_support.h"

#include <gsl/gsl_errno.h>

#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

namespace servokit {

void UseGslStatusCodes() {
  static std::once_flag once;
  std::call_once(once, [] { gsl_set_error_handler_off(); });
}

std::optional<RootBracket> NarrowBracket(const gsl_root_fsolver_type* type,
                                         const std::function<double(double)>& function,
                                         double lower,
                                         double upper,
                                         double relative_tolerance,
                                         double absolute_tolerance) {
  UseGslStatusCodes();
  using Function = std::function<double(double)>;
  gsl_function adapter{
      [](double x, void* data) { return (*static_cast<const Function*>(data))(x); },
      const_cast<Function*>(&function)};
  std::unique_ptr<gsl_root_fsolver, void (*)(gsl_root_fsolver*)> solver(
      gsl_root_fsolver_alloc(type), gsl_root_fsolver_free);
  if (!solver || gsl_root_fsolver_set(solver.get(), &adapter, lower, upper) != GSL_SUCCESS) {
    return std::nullopt;
  }
  // Bisection halves the bracket each time, so 200 iterations reach any double-precision
  // width; Brent needs far fewer on a smooth function.
  constexpr int kMaxIterations = 200;
  RootBracket bracket{lower, upper, 0.5 * (lower + upper), false};
  for (int i = 0; i < kMaxIterations; ++i) {
    if (gsl_root_fsolver_iterate(solver.get()) != GSL_SUCCESS) break;
    bracket = {gsl_root_fsolver_x_lower(solver.get()), gsl_root_fsolver_x_upper(solver.get()),
               gsl_root_fsolver_root(solver.get()), false};
    if (gsl_root_test_interval(bracket.lower, bracket.upper, absolute_tolerance,
                               relative_tolerance) == GSL_SUCCESS) {
      bracket.converged = true;
      break;
    }
    // Two adjacent doubles: the bracket cannot shrink further.
    if (bracket.upper - bracket.lower <=
        4 * std::numeric_limits<double>::epsilon() * std::abs(bracket.upper)) {
      break;
    }
  }
  return bracket;
}

}  // namespace servokit
