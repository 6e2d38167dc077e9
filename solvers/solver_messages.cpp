#include "solvers/solver_messages.h"

#include <sstream>

#include "models/errors.h"

namespace servokit {

std::string FormatNumber(double value) {
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

void RequireOption(bool valid,
                   const char* owner,
                   const char* field,
                   double value,
                   const std::string& rule) {
  if (!valid) {
    throw UsageError(std::string(owner) + "::" + field + " = " + FormatNumber(value) + ": " + rule);
  }
}

}  // namespace servokit
