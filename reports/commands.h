#pragma once
// The subcommands of `servokit`, one file each (reports/<name>_command.cpp), and the argument
// parsing they share. Each Add*Command registers its options on `app` and returns the function
// that runs it once the command line has been parsed.
#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

#include "models/model.h"

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

/// "--set name=value" texts into overrides; throws UsageError naming a malformed one.
std::vector<ParameterOverride> ParseOverrides(const std::vector<std::string>& texts);

/// "--y0 1,2 --y0 3" -> [1, 2, 3]; each value may end in "deg". Throws UsageError naming
/// `option` and the bad value.
Eigen::VectorXd ParseValues(const std::string& option, const std::vector<std::string>& texts);

}  // namespace servokit
