#pragma once
// The errors servokit reports, part of its public API (servokit/servokit.h, which includes this
// header). They sit in the lowest layer, base/, so that every layer throws them and a library
// user catches the same classes. Each error has a kind, which the command line
// maps to its documented exit status (application/exit_codes.h) and a C++ or Python caller may
// switch on; what() is one line in the toolkit's words, without a "servokit: error:" prefix.
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/vocabulary.h"

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

// The errors below carry what went wrong as values, so that a caller (the command line names
// its own flags) can say it in its own words; what() is the toolkit's sentence.

/// An option struct's field with a value it cannot take (kind kUsage): what() is
/// "<owner>::<field> = <value>: <rule>", owner() and field() name the field
/// ("ClassificationOptions", "rank_tolerance").
class OptionError : public UsageError {
 public:
  OptionError(std::string_view owner,
              std::string_view field,
              std::string_view value,
              std::string_view rule)
      : UsageError(std::string(owner) + "::" + std::string(field) + " = " + std::string(value) +
                   ": " + std::string(rule)),
        owner_(owner),
        field_(field) {}
  const std::string& owner() const { return owner_; }
  const std::string& field() const { return field_; }

 private:
  std::string owner_;
  std::string field_;
};

/// A parameter override the model cannot take: an unknown name or a value that is not a number
/// (kind kUsage). what() is "parameter override <name>=<value>: <problem>".
class ParameterOverrideError : public UsageError {
 public:
  ParameterOverrideError(std::string name, std::string value, const std::string& problem)
      : UsageError("parameter override " + name + "=" + value + ": " + problem),
        name_(std::move(name)),
        value_(std::move(value)),
        problem_(problem) {}
  const std::string& name() const { return name_; }
  const std::string& value() const { return value_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string name_, value_, problem_;
};

/// A solve setting that does not fit the method or the motion (kind kUsage); setting() says
/// which, for a caller that names it its own way (the command line: its flag).
class SettingError : public UsageError {
 public:
  SettingError(SolveSetting setting, const std::string& message)
      : UsageError(message), setting_(setting) {}
  SolveSetting setting() const { return setting_; }

 private:
  SolveSetting setting_;
};

/// A method that does not fit the problem's class (kind kNoSolution).
class MethodRefused : public NoSolution {
 public:
  MethodRefused(const std::string& message,
                std::vector<SolverMethod> alternatives,
                std::vector<SolverMethod> forceable)
      : NoSolution(message),
        alternatives_(std::move(alternatives)),
        forceable_(std::move(forceable)) {}
  /// Methods that accept the problem.
  const std::vector<SolverMethod>& alternatives() const { return alternatives_; }
  /// Methods that would accept it if forced (unstable zero dynamics integrated forward).
  const std::vector<SolverMethod>& forceable() const { return forceable_; }

 private:
  std::vector<SolverMethod> alternatives_;
  std::vector<SolverMethod> forceable_;
};

}  // namespace servokit
