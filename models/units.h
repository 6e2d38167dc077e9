#pragma once
// SI in, SI out: the one place where "<number> deg" becomes radians (STYLE.md, units).
#include <optional>
#include <string_view>

namespace servokit {

/// Parses "<number>" or "<number> deg" (blank before "deg" optional) into SI units, degrees
/// converted to radians. Returns std::nullopt for anything else, including NaN and Inf.
std::optional<double> ParseQuantity(std::string_view text);

/// Radians to degrees, for reports.
double RadiansToDegrees(double radians);

}  // namespace servokit
