#include <string>

#include "application/commands.h"
#include "servokit/servokit.h"

namespace servokit {

void AddLinearModelOptions(CLI::App& command,
                           LinearModelArguments& arguments,
                           const std::string& what) {
  command
      .add_option(
          "--eigenvalues", arguments.eigenvalues,
          "Linear models: how many " + what + " ARPACK computes (the dense route computes all)")
      ->capture_default_str();
  command
      .add_option("--shift", arguments.shift,
                  "Linear models: real shift sigma (1/s) of the shift-invert (A - sigma E)^-1 E; "
                  "must not be a zero")
      ->capture_default_str();
  command
      .add_option("--eigen-solver", arguments.eigen_solver,
                  "Linear models: auto (dense up to 200 coordinates, ARPACK above), dense (every "
                  "zero, O(n^3)) or arpack (K zeros, shift-invert)")
      ->capture_default_str();
  command
      .add_option("--which", arguments.which,
                  "Linear models, ARPACK: nearest (the K zeros nearest the shift: the slowest "
                  "modes) or rightmost (largest Re 1/(lambda - shift): any zero right of the "
                  "shift ranks first, which decides stability at shift 0)")
      ->capture_default_str();
}

void ApplyLinearModelArguments(const LinearModelArguments& arguments,
                               bool y0_given,
                               bool q0_given,
                               api::AnalyzeOptions& options) {
  // The flags' own words first; the options' rules are the library's (one place for them).
  if (y0_given || q0_given) {
    throw UsageError(std::string(y0_given ? "--y0" : "--q0") +
                     ": a linear model is analysed at q = 0, y = 0; the option does not apply");
  }
  const std::optional<LinearEigenSolver> solver =
      LinearEigenSolverFromString(arguments.eigen_solver);
  if (!solver) {
    throw UsageError("--eigen-solver " + arguments.eigen_solver +
                     ": expected auto, dense or arpack");
  }
  const std::optional<EigenvalueTarget> target = EigenvalueTargetFromString(arguments.which);
  if (!target) {
    throw UsageError("--which " + arguments.which + ": expected nearest or rightmost");
  }
  options.eigenvalues = arguments.eigenvalues;
  options.shift = arguments.shift;
  options.eigen_solver = *solver;
  options.which = *target;
}

void RefuseLinearModelOptions(const CLI::App& command) {
  for (const char* name : kLinearModelOptions) {
    if (command.get_option(name)->count() > 0) {
      throw UsageError(std::string(name) + ": applies to linear models (`kind: linear`) only");
    }
  }
}

}  // namespace servokit
