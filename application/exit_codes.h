#pragma once
// The documented exit statuses of `servokit` (docs/errors.md, "Exit statuses") and the one function
// that maps an error to its status.
#include <exception>

namespace servokit {

enum class ExitCode : int {
  kSuccess = 0,
  kOther = 1,       // anything else (I/O failure, internal error)
  kBadInput = 2,    // bad usage or a bad model file (UsageError, ModelError)
  kNoSolution = 3,  // no solution of the kind asked (NoSolution, unusable solver summary)
  // A solve that finished, but whose u_d, driving the model (--verify), does not reproduce
  // y_d within the stated bound.
  kVerificationFailed = 4,
};

/// The exit status for an exception that reached the command line.
ExitCode ExitCodeFor(const std::exception& error);

}  // namespace servokit
