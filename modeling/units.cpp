#include "modeling/units.h"

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <system_error>

#include "base/text.h"

namespace servokit {
namespace {

constexpr std::string_view kDegreeSuffix = "deg";
constexpr std::string_view kRadianSuffix = "rad";
constexpr double kInfinity = std::numeric_limits<double>::infinity();

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
  text = TrimBlanks(text);
  if (text.ends_with(kDegreeSuffix)) {
    const std::optional<double> degrees =
        ParseNumber(TrimBlanks(text.substr(0, text.size() - kDegreeSuffix.size())));
    if (!degrees) {
      return std::nullopt;
    }
    return ParsedQuantity{DegreesToRadians(*degrees), DisplayUnit::kDegree, true};
  }
  if (text.ends_with(kRadianSuffix)) {
    const std::optional<double> radians =
        ParseNumber(TrimBlanks(text.substr(0, text.size() - kRadianSuffix.size())));
    if (!radians) return std::nullopt;
    return ParsedQuantity{*radians, DisplayUnit::kSI, true};
  }
  const std::optional<double> value = ParseNumber(text);
  if (!value) return std::nullopt;
  return ParsedQuantity{*value, DisplayUnit::kSI, false};
}

ParsedQuantity InDeclaredUnit(ParsedQuantity quantity, DisplayUnit declared) {
  if (quantity.unit_written || declared != DisplayUnit::kDegree) return quantity;
  return ParsedQuantity{DegreesToRadians(quantity.value), DisplayUnit::kDegree, false};
}

std::optional<double> ParseQuantity(std::string_view text) {
  const std::optional<ParsedQuantity> quantity = ParseQuantityWithUnit(text);
  if (!quantity) return std::nullopt;
  return quantity->value;
}

double DegreesToRadians(double degrees) { return degrees * std::numbers::pi / 180.0; }

double RadiansToDegrees(double radians) { return radians * 180.0 / std::numbers::pi; }

double DisplayDegrees(double radians) {
  // Zero is zero in any unit. (The search below would step from -5e-324 to -0 and past +0, and
  // show 0 deg as -0 in a table that keeps the sign, such as HDF5's.)
  if (radians == 0.0) return radians;
  // A sweep asks for the same few angles again and again (a degree range's ends, for each of its
  // points, and each point shown): the last four answers of this thread are kept, keyed by their
  // bits (so that -0 and 0 stay apart and the answer never depends on what was asked before).
  struct Answer {
    std::uint64_t radians_bits = 0;
    double degrees = 0.0;
    bool set = false;
  };
  thread_local std::array<Answer, 4> answers;
  thread_local std::size_t next_answer = 0;
  const auto bits = std::bit_cast<std::uint64_t>(radians);
  for (const Answer& answer : answers) {
    if (answer.set && answer.radians_bits == bits) return answer.degrees;
  }
  // Two roundings each way: the degree value that was given lies within a few ulps of the
  // product. Searching +-kUlps steps is enough and cheap.
  constexpr int kUlps = 4;
  const double nearest = RadiansToDegrees(radians);
  double best = nearest;
  if (std::isfinite(nearest)) {
    std::array<double, 2 * kUlps + 1> exact{};
    std::size_t count = 0;
    double candidate = nearest;
    for (int i = 0; i < kUlps; ++i) candidate = std::nextafter(candidate, -kInfinity);
    for (int i = -kUlps; i <= kUlps; ++i) {
      if (DegreesToRadians(candidate) == radians) exact[count++] = candidate;
      candidate = std::nextafter(candidate, kInfinity);
    }
    if (count == 1) best = exact[0];
    std::size_t best_length = std::numeric_limits<std::size_t>::max();
    for (std::size_t i = 0; count > 1 && i < count; ++i) {
      char text[32];
      const auto result = std::to_chars(text, text + sizeof text, exact[i]);  // shortest form
      const auto length = static_cast<std::size_t>(result.ptr - text);
      // Of equally short ones, the one nearest the product (the lower one if two are as near).
      if (length < best_length ||
          (length == best_length && std::abs(exact[i] - nearest) < std::abs(best - nearest))) {
        best = exact[i];
        best_length = length;
      }
    }
  }
  answers[next_answer] = {bits, best, true};
  next_answer = (next_answer + 1) % answers.size();
  return best;
}

}  // namespace servokit
