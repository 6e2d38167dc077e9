#include "models/units.h"

#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>
#include <system_error>

namespace servokit {
namespace {

constexpr std::string_view kDegreeSuffix = "deg";
constexpr std::string_view kBlanks = " \t";
constexpr double kInfinity = std::numeric_limits<double>::infinity();

std::string_view Trim(std::string_view text) {
  const std::size_t first = text.find_first_not_of(kBlanks);
  if (first == std::string_view::npos) {
    return {};
  }
  const std::size_t last = text.find_last_not_of(kBlanks);
  return text.substr(first, last - first + 1);
}

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

std::string_view ToString(DisplayUnit unit) { return unit == DisplayUnit::kDegree ? "deg" : "SI"; }

std::optional<ParsedQuantity> ParseQuantityWithUnit(std::string_view text) {
  text = Trim(text);
  if (text.ends_with(kDegreeSuffix)) {
    const std::optional<double> degrees =
        ParseNumber(Trim(text.substr(0, text.size() - kDegreeSuffix.size())));
    if (!degrees) {
      return std::nullopt;
    }
    return ParsedQuantity{DegreesToRadians(*degrees), DisplayUnit::kDegree};
  }
  const std::optional<double> value = ParseNumber(text);
  if (!value) return std::nullopt;
  return ParsedQuantity{*value, DisplayUnit::kSI};
}

std::optional<double> ParseQuantity(std::string_view text) {
  const std::optional<ParsedQuantity> quantity = ParseQuantityWithUnit(text);
  if (!quantity) return std::nullopt;
  return quantity->value;
}

double DegreesToRadians(double degrees) { return degrees * std::numbers::pi / 180.0; }

double RadiansToDegrees(double radians) { return radians * 180.0 / std::numbers::pi; }

double DisplayDegrees(double radians) {
  // Two roundings each way: the degree value that was given lies within a few ulps of the
  // product. Searching +-kUlps steps is enough and cheap (to_chars of 9 doubles).
  constexpr int kUlps = 4;
  const double nearest = RadiansToDegrees(radians);
  if (!std::isfinite(nearest)) return nearest;
  double best = nearest;
  std::size_t best_length = std::numeric_limits<std::size_t>::max();
  double candidate = nearest;
  for (int i = 0; i < kUlps; ++i) candidate = std::nextafter(candidate, -kInfinity);
  for (int i = -kUlps; i <= kUlps; ++i) {
    if (DegreesToRadians(candidate) == radians) {
      char text[32];
      const auto result = std::to_chars(text, text + sizeof text, candidate);  // shortest form
      const auto length = static_cast<std::size_t>(result.ptr - text);
      // Of equally short ones, the one nearest the product (the lower one if two are as near).
      if (length < best_length ||
          (length == best_length && std::abs(candidate - nearest) < std::abs(best - nearest))) {
        best = candidate;
        best_length = length;
      }
    }
    candidate = std::nextafter(candidate, kInfinity);
  }
  return best;
}

}  // namespace servokit
