#pragma once
// The errors servokit reports, part of its public API (servokit/servokit.h, which includes this
// header). They sit in the lowest layer, base/, so that every layer throws them and a library
// user catches the same classes. Each error has a kind, which the command line
// maps to its documented exit status (application/exit_codes.h) and a C++ or Python caller may
// switch on; what() is one line in the toolkit's words, without a "servokit: error:" prefix.
#include <stdexcept>
#include <string>

namespace servokit {

/// What went wrong, as a caller decides on it.
enum class ErrorKind {
  kUsage,       // bad options or arguments: fix the call
  kModel,       // a bad model file: fix the file ("file: key: entry: problem")
  kNoSolution,  // no solution of the kind asked: singular, non-hyperbolic, no convergence
  kOther,       // anything else: a file that cannot be written, an internal failure
};

/// Base of every error meant for the user.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what, ErrorKind kind = ErrorKind::kOther)
      : std::runtime_error(what), kind_(kind) {}
  ErrorKind kind() const noexcept { return kind_; }

 private:
  ErrorKind kind_;
};

/// Bad options or arguments (kind kUsage; exit status 2).
class UsageError : public Error {
 public:
  explicit UsageError(const std::string& what) : Error(what, ErrorKind::kUsage) {}
};

/// Bad model file, written as "file: key: entry: problem" (kind kModel; exit status 2).
class ModelError : public Error {
 public:
  explicit ModelError(const std::string& what) : Error(what, ErrorKind::kModel) {}
};

/// No solution of the kind asked: singular, non-hyperbolic, no convergence (kind kNoSolution;
/// exit status 3).
class NoSolution : public Error {
 public:
  explicit NoSolution(const std::string& what) : Error(what, ErrorKind::kNoSolution) {}
};

}  // namespace servokit
