#include "models/units.h"

#include <charconv>
#include <cmath>
#include <numbers>
#include <system_error>

namespace servokit {
namespace {

constexpr std::string_view kDegreeSuffix = "deg";
constexpr std::string_view kBlanks = " \t";

std::string_view Trim(std::string_view text) {
  const std::size_t first = text.find_first_not_of(kBlanks);
  if (first == std::string_view::npos) {
    return {};
  }
  const std::size_t last = text.find_last_not_of(kBlanks);
  return text.substr(first, last - first + 1);
}

double DegreesToRadians(double degrees) { return degrees * std::numbers::pi / 180.0; }

// The whole of `text` must be one finite decimal number; from_chars rejects hex and leading '+'
// in this mode, and reports overflow (1e400) as out of range.
std::optional<double> ParseNumber(std::string_view text) {
  if (text.empty()) {
    return std::nullopt;
  }
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  if (error != std::errc() || stop != end || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

}  // namespace

std::optional<double> ParseQuantity(std::string_view text) {
  text = Trim(text);
  if (text.ends_with(kDegreeSuffix)) {
    const std::optional<double> degrees =
        ParseNumber(Trim(text.substr(0, text.size() - kDegreeSuffix.size())));
    if (!degrees) {
      return std::nullopt;
    }
    return DegreesToRadians(*degrees);
  }
  return ParseNumber(text);
}

double RadiansToDegrees(double radians) { return radians * 180.0 / std::numbers::pi; }

}  // namespace servokit
