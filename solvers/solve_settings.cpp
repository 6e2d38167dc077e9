#include "solvers/solve_settings.h"

#include <cassert>
#include <cmath>

#include "solvers/solver_messages.h"

namespace servokit {

std::string_view ToString(SolveSetting setting) {
  switch (setting) {
    case SolveSetting::kMethod:
      return "method";
    case SolveSetting::kForce:
      return "forcing";
    case SolveSetting::kStartTime:
      return "start time";
    case SolveSetting::kEndTime:
      return "end time";
    case SolveSetting::kStep:
      return "step";
    case SolveSetting::kRelativeTolerance:
      return "relative tolerance";
    case SolveSetting::kAbsoluteTolerance:
      return "absolute tolerance";
    case SolveSetting::kSampleTime:
      return "sample time";
    case SolveSetting::kPreActuation:
      return "pre-actuation";
    case SolveSetting::kPostActuation:
      return "post-actuation";
  }
  return "setting";
}

const MethodSettings& SettingsOf(SolverMethod method) {
  // Radau's and SUNDIALS' floor: 10 eps relative is lost to rounding x after each step.
  constexpr double kIntegratorMinRtol = 1e-14;
  // The boundary value problem's floor (BoundaryValueOptions::tolerance >= 1e-12).
  constexpr double kCollocationMinRtol = 1e-12;
  constexpr double kPaperStep = 1e-3;
  static const MethodSettings kAlgebraic = {.uses_step = true, .default_step = kPaperStep};
  static const MethodSettings kEuler = {.uses_step = true,
                                        .uses_tolerances = true,
                                        .forward = true,
                                        .default_rtol = 1e-8,
                                        .default_atol = 1e-10,
                                        .min_rtol = kIntegratorMinRtol,
                                        .default_step = kPaperStep};
  static const MethodSettings kRadau = {.uses_tolerances = true,
                                        .forward = true,
                                        .default_rtol = 1e-8,
                                        .default_atol = 1e-10,
                                        .min_rtol = kIntegratorMinRtol};
  static const MethodSettings kSundials = {.uses_tolerances = true,
                                           .forward = true,
                                           .default_rtol = 1e-10,
                                           .default_atol = 1e-12,
                                           .min_rtol = kIntegratorMinRtol};
  static const MethodSettings kStableInversion = {.uses_tolerances = true,
                                                  .uses_actuation = true,
                                                  .default_rtol = 1e-8,
                                                  .default_atol = 1e-10,
                                                  .min_rtol = kCollocationMinRtol};
  switch (method) {
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
                         "relative tolerance " + FormatNumber(*rtol) +
                             " is below the smallest " + std::string(ToString(method)) +
                             " supports, " + FormatNumber(settings.min_rtol));
    }
    if (*rtol > kMaxRelativeTolerance) {
      throw SettingError(SolveSetting::kRelativeTolerance,
                         "relative tolerance " + FormatNumber(*rtol) + " is above the largest "
                         "supported, " + FormatNumber(kMaxRelativeTolerance));
    }
  }
  if (atol && !(std::isfinite(*atol) && *atol > 0.0)) {
    throw SettingError(SolveSetting::kAbsoluteTolerance,
                       "absolute tolerance " + FormatNumber(*atol) + " is not a finite number > 0");
  }
}

}  // namespace servokit
