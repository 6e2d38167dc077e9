#include "base/option_check.h"

namespace servokit {
namespace {

std::string OptionMessage(std::string_view owner,
                          std::string_view field,
                          std::string_view value,
                          std::string_view rule) {
  std::string message(owner);
  message.append("::").append(field).append(" = ").append(value).append(": ").append(rule);
  return message;
}

}  // namespace

std::string OptionValueText(const Eigen::VectorXd& values) {
  std::string text = "[";
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    text += (i ? ", " : "") + FormatNumber(values(i));
  }
  return text + "]";
}

OptionError::OptionError(std::string_view owner,
                         std::string_view field,
                         std::string_view value,
                         std::string_view rule)
    : UsageError(OptionMessage(owner, field, value, rule)), owner_(owner), field_(field) {}

}  // namespace servokit
