#include "application/exit_codes.h"

#include "servokit/servokit.h"

namespace servokit {

ExitCode ExitCodeFor(const std::exception& error) {
  const auto* servokit_error = dynamic_cast<const Error*>(&error);
  if (servokit_error == nullptr) return ExitCode::kOther;
  switch (servokit_error->kind()) {
    case ErrorKind::kUsage:
    case ErrorKind::kModel:
      return ExitCode::kBadInput;
    case ErrorKind::kNoSolution:
      return ExitCode::kNoSolution;
    case ErrorKind::kOther:
      return ExitCode::kOther;
  }
  return ExitCode::kOther;
}

}  // namespace servokit
