#pragma once
// Runs the `servokit` command line in-process and keeps what it printed (tests of reports/).
#include <sstream>
#include <string>
#include <vector>

#include "application/command_line.h"

namespace servokit::testing {

struct Run {
  int status = -1;
  std::string out, err;
};

inline Run RunServokit(std::vector<std::string> arguments) {
  arguments.insert(arguments.begin(), "servokit");
  std::vector<const char*> argv;
  for (const auto& argument : arguments) argv.push_back(argument.c_str());
  std::ostringstream out, err;
  Run run;
  run.status = RunCommandLine(int(argv.size()), argv.data(), out, err);
  run.out = out.str();
  run.err = err.str();
  return run;
}

}  // namespace servokit::testing
