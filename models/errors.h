#pragma once
// The errors servokit reports to a user. They live in the lowest layer so that every folder
// can throw them; reports/exit_codes.h maps each class to the documented exit status.
#include <stdexcept>

namespace servokit {

/// Base of every error meant for the user; what() is one line without the "servokit: error:"
/// prefix.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bad command line or bad options (exit status 2).
class UsageError : public Error {
 public:
  using Error::Error;
};

/// Bad model file, written as "file: key: entry: problem" (exit status 2).
class ModelError : public Error {
 public:
  using Error::Error;
};

/// No solution of the kind asked: singular, non-hyperbolic, no convergence (exit status 3).
class NoSolution : public Error {
 public:
  using Error::Error;
};

}  // namespace servokit
