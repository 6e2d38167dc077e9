#include "solvers/solve_settings.h"

#include <cassert>
#include <cmath>

#include "base/option_check.h"
#include "integrators/boundary_value.h"
#include "integrators/radau.h"
#include "integrators/sundials_integrators.h"
#include "solvers/stable_inversion.h"

namespace servokit {

const MethodSettings& SettingsOf(SolverMethod method) {
  // The defaults are the solvers' own (their options structs say why); the table only collects
  // them. SUNDIALS' BDF and Dormand-Prince lose digits below Radau's floor for the same reason.
  static const RadauOptions radau;
  static const IntegratorOptions sundials;
  static const StableInversionOptions collocation;
  constexpr double kPaperStep = 1e-3;  // the paper's finest Euler step (Fig. 10)
  static const MethodSettings kAlgebraic = {.uses_step = true, .default_step = kPaperStep};
  static const MethodSettings kEuler = {.uses_step = true,
                                        .uses_tolerances = true,
                                        .forward = true,
                                        .default_rtol = radau.rtol,
                                        .default_atol = radau.atol,
                                        .min_rtol = kRadauMinRelativeTolerance,
                                        .default_step = kPaperStep};
  static const MethodSettings kRadau = {.uses_tolerances = true,
                                        .forward = true,
                                        .default_rtol = radau.rtol,
                                        .default_atol = radau.atol,
                                        .min_rtol = kRadauMinRelativeTolerance};
  static const MethodSettings kSundials = {.uses_tolerances = true,
                                           .forward = true,
                                           .default_rtol = sundials.rtol,
                                           .default_atol = sundials.atol,
                                           .min_rtol = kRadauMinRelativeTolerance};
  static const MethodSettings kStableInversion = {.uses_tolerances = true,
                                                  .uses_actuation = true,
                                                  .default_rtol = collocation.tolerance,
                                                  .default_atol = collocation.absolute_tolerance,
                                                  .min_rtol = kBoundaryValueMinTolerance};
  // The linearization's own inverse reads the algebraic inverse's step and stable inversion's
  // tolerances and actuation times, whichever it uses.
  static const MethodSettings kLinearized = {.uses_step = true,
                                             .uses_tolerances = true,
                                             .uses_actuation = true,
                                             .default_rtol = collocation.tolerance,
                                             .default_atol = collocation.absolute_tolerance,
                                             .min_rtol = kBoundaryValueMinTolerance,
                                             .default_step = kPaperStep};
  switch (method) {
    case SolverMethod::kLinearized:
      return kLinearized;
    case SolverMethod::kAlgebraic:
      return kAlgebraic;
    case SolverMethod::kEuler:
      return kEuler;
    case SolverMethod::kRadau:
      return kRadau;
    case SolverMethod::kBdf:
    case SolverMethod::kNormalForm:
      return kSundials;
    case SolverMethod::kStableInversion:
      return kStableInversion;
    case SolverMethod::kAuto:
      break;
  }
  assert(false && "SettingsOf(kAuto)");
  return kRadau;
}

void CheckTolerances(SolverMethod method, std::optional<double> rtol, std::optional<double> atol) {
  const MethodSettings& settings = SettingsOf(method);
  if (rtol) {
    if (!std::isfinite(*rtol) || !(*rtol > 0.0)) {
      throw SettingError(SolveSetting::kRelativeTolerance,
                         "relative tolerance " + FormatNumber(*rtol) + " is not a number > 0");
    }
    if (*rtol < settings.min_rtol) {
      throw SettingError(SolveSetting::kRelativeTolerance,
                         "relative tolerance " + FormatNumber(*rtol) + " is below the smallest " +
                             std::string(ToString(method)) + " supports, " +
                             FormatNumber(settings.min_rtol));
    }
    if (*rtol > kMaxRelativeTolerance) {
      throw SettingError(SolveSetting::kRelativeTolerance, "relative tolerance " +
                                                               FormatNumber(*rtol) +
                                                               " is above the largest "
                                                               "supported, " +
                                                               FormatNumber(kMaxRelativeTolerance));
    }
  }
  if (atol && !(std::isfinite(*atol) && *atol > 0.0)) {
    throw SettingError(SolveSetting::kAbsoluteTolerance,
                       "absolute tolerance " + FormatNumber(*atol) + " is not a finite number > 0");
  }
}

}  // namespace servokit
