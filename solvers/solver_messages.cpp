#include "solvers/solver_messages.h"

#include <charconv>
#include <cmath>

#include "models/errors.h"

namespace servokit {

std::string FormatNumber(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
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
