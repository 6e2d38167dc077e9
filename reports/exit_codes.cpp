#include "reports/exit_codes.h"

#include "models/errors.h"

namespace servokit {

ExitCode ExitCodeFor(const std::exception& error) {
  if (dynamic_cast<const UsageError*>(&error) || dynamic_cast<const ModelError*>(&error)) {
    return ExitCode::kBadInput;
  }
  if (dynamic_cast<const NoSolution*>(&error)) return ExitCode::kNoSolution;
  return ExitCode::kOther;
}

}  // namespace servokit
