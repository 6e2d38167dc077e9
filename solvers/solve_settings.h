#pragma once
// The settings a user chooses for a solve, and the one table of what each method reads, its
// default tolerances and the range it supports. Each default and limit is owned by the solver
// it belongs to (RadauOptions, IntegratorOptions, StableInversionOptions and their floors);
// this table collects them for the inverse model and nothing else writes them. Messages name
// a setting in the toolkit's words ("relative tolerance"), and SettingError lets an
// application name its own flag for it.
#include <optional>
#include <string>
#include <string_view>

#include "base/errors.h"
#include "base/vocabulary.h"

namespace servokit {

/// What a user sets for a solve (InverseModelOptions).
std::string_view ToString(SolveSetting setting);

/// A setting out of its range, or one that the chosen method does not use. what() speaks the
/// toolkit's words; setting() tells an application which of its own options it was.
/// What a method reads and what it accepts.
struct MethodSettings {
  bool uses_step = false;        // Euler backward's step; the algebraic inverse's spacing
  bool uses_tolerances = false;  // rtol and atol
  bool uses_actuation = false;   // pre- and post-actuation (stable inversion)
  bool forward = false;          // integrates the internal dynamics forward (can be forced)
  // Defaults, the solvers' own (the table of docs/solve.md "Tolerances and steps"): Radau
  // IIA and Euler backward 1e-8 / 1e-10 (RadauOptions), Dormand-Prince and BDF 1e-10 / 1e-12
  // (IntegratorOptions), stable inversion 1e-8 / 1e-10 (StableInversionOptions).
  double default_rtol = 0.0;
  double default_atol = 0.0;
  // The smallest relative tolerance the method reaches (kRadauMinRelativeTolerance,
  // kBoundaryValueMinTolerance).
  double min_rtol = 0.0;
  // Euler backward: the paper's finest step (Fig. 10); algebraic inverse: its sample spacing.
  double default_step = 0.0;
};

/// The table's row for `method` (not kAuto).
const MethodSettings& SettingsOf(SolverMethod method);

/// The largest relative tolerance any method accepts: beyond it an answer has no digit left.
inline constexpr double kMaxRelativeTolerance = 0.1;

/// Throws SettingError unless `rtol` is within [SettingsOf(method).min_rtol,
/// kMaxRelativeTolerance] and `atol` is finite and > 0 (either may be unset).
void CheckTolerances(SolverMethod method, std::optional<double> rtol, std::optional<double> atol);

}  // namespace servokit
