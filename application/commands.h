#pragma once
// The subcommands of `servokit`, one file each (application/<name>_command.cpp), and the argument
// parsing they share. Each Add*Command registers its options on `app` and returns the function
// that runs it once the command line has been parsed.
#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "servokit/servokit.h"

namespace servokit {

/// Runs a parsed subcommand; returns the exit status, throws servokit errors.
using CommandRunner = std::function<int(std::ostream& out, std::ostream& err)>;

struct Command {
  CLI::App* app = nullptr;  // the subcommand, to ask whether it was given
  CommandRunner run;
};

Command AddAnalyzeCommand(CLI::App& app);
Command AddGenerateCommand(CLI::App& app);
Command AddThresholdCommand(CLI::App& app);
Command AddReportCommand(CLI::App& app);
Command AddSolveCommand(CLI::App& app);
Command AddSweepCommand(CLI::App& app);

/// The options `analyze` and `sweep` take for linear models, as given on the command line.
struct LinearModelArguments {
  int eigenvalues = api::DefaultAnalyzeOptions().eigenvalues;
  double shift = api::DefaultAnalyzeOptions().shift;
  std::string eigen_solver = std::string(ToString(api::DefaultAnalyzeOptions().eigen_solver));
  std::string which = std::string(ToString(api::DefaultAnalyzeOptions().which));
};

/// Their names, so that a command can refuse them for a multibody model.
inline constexpr const char* kLinearModelOptions[] = {"--eigenvalues", "--shift", "--eigen-solver",
                                                      "--which"};

/// Throws UsageError naming the first of kLinearModelOptions given to `command`: a multibody
/// model has no use for them, and ignoring them would hide a mistake.
void RefuseLinearModelOptions(const CLI::App& command);

/// Registers --eigenvalues, --shift, --eigen-solver and --which on `command`; `what` ends each
/// help text's first words ("zeros", "zeros per point").
void AddLinearModelOptions(CLI::App& command,
                           LinearModelArguments& arguments,
                           const std::string& what);

/// Sets the linear-model fields of `options` from `arguments`. Throws UsageError naming a bad
/// --eigen-solver or --which, or --y0/--q0 when given (a linear model is analysed at q = 0,
/// y = 0); the library checks the values themselves when it analyses.
void ApplyLinearModelArguments(const LinearModelArguments& arguments,
                               bool y0_given,
                               bool q0_given,
                               api::AnalyzeOptions& options);

/// Makes the directory `--out` names (and its parents). Throws Error (exit status 1, as for any
/// file that cannot be written) naming --out and the system's reason.
void MakeOutputDirectory(const std::string& directory);

/// "--set name=value" texts into the API's parameter values (servokit/servokit.h); throws
/// UsageError naming a malformed one.
api::ParameterValues ParseParameterValues(const std::vector<std::string>& texts);

/// "--y0 1,2 --y0 3" -> [1, 2, 3]; each value may end in "deg". Throws UsageError naming
/// `option` and the bad value.
Eigen::VectorXd ParseValues(const std::string& option, const std::vector<std::string>& texts);

}  // namespace servokit
