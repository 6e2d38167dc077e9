#pragma once
// The one way servokit checks an options struct and writes a number in a message. Every
// Validate() calls RequireOption, so that each message reads "Owner::field = value: rule"
// (style: the message names the field, its value and the rule it breaks, docs/development.md),
// and every message that shows a number, in any folder, writes it with FormatNumber
// (base/number_format.h).
#include <Eigen/Core>
#include <string>
#include <string_view>
#include <type_traits>

#include "base/errors.h"
#include "base/number_format.h"

namespace servokit {

/// An option that breaks its rule. what() is "<owner>::<field> = <value>: <rule>"; owner() and
/// field() let an application name its own option (a command-line flag) for the field.
/// A vector of values as an option message writes it, each by FormatNumber: "[1, 0.25]".
std::string OptionValueText(const Eigen::VectorXd& values);

/// The value as an option message writes it: a floating-point number by FormatNumber, an
/// integer exactly, a vector as above, and text (a shape "3 x 2") as it is.
template <typename Value>
std::string OptionValueText(const Value& value) {
  if constexpr (std::is_floating_point_v<Value>) {
    return FormatNumber(static_cast<double>(value));
  } else if constexpr (std::is_integral_v<Value>) {
    return std::to_string(value);
  } else if constexpr (std::is_base_of_v<Eigen::EigenBase<Value>, Value>) {
    return OptionValueText(Eigen::VectorXd(value));  // a fixed-size vector or an expression
  } else {
    return std::string(std::string_view(value));
  }
}

/// Throws OptionError "<owner>::<field> = <value>: <rule>" unless `holds`.
template <typename Value>
void RequireOption(bool holds,
                   std::string_view owner,
                   std::string_view field,
                   const Value& value,
                   std::string_view rule) {
  if (!holds) throw OptionError(owner, field, OptionValueText(value), rule);
}

}  // namespace servokit
