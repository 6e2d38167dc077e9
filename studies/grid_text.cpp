#include "studies/grid_text.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <numbers>
#include <optional>
#include <system_error>
#include <utility>

#include "base/errors.h"
#include "base/text.h"
#include "modeling/units.h"
#include "reports/sweep_tables.h"

namespace servokit {
namespace {

std::vector<std::string_view> Split(std::string_view text, char separator) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  for (std::size_t end = text.find(separator); end != std::string_view::npos;
       end = text.find(separator, start)) {
    parts.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  parts.push_back(text.substr(start));
  return parts;
}

// `argument` is the axis's text as its caller names it ("--vary alpha=0:1:3" on the command line).
UsageError VaryError(std::string_view argument, const std::string& problem) {
  return UsageError(std::string(argument) + ": " + problem);
}

ParsedQuantity ParseValue(std::string_view argument, std::string_view item) {
  const std::optional<ParsedQuantity> value = ParseQuantityWithUnit(item);
  if (!value) {
    throw VaryError(argument, "'" + std::string(TrimBlanks(item)) +
                                  "' is not a number (use e.g. 0.5 or \"5 deg\")");
  }
  return *value;
}

std::size_t ParseCount(std::string_view argument, std::string_view item) {
  const std::string_view digits = TrimBlanks(item);
  long long count = 0;
  const char* end = digits.data() + digits.size();
  const auto [stop, error] = std::from_chars(digits.data(), end, count);
  if (digits.empty() || error != std::errc() || stop != end) {
    throw VaryError(argument, "'" + std::string(digits) + "' is not a whole number of values");
  }
  if (count < 1) {
    throw VaryError(argument,
                    "the number of values must be at least 1, got " + std::to_string(count));
  }
  return static_cast<std::size_t>(count);
}

std::size_t VariedParameter(const std::vector<std::string>& parameter_names,
                            std::string_view argument,
                            std::string_view name) {
  try {
    return ParameterIndex(parameter_names, name);
  } catch (const UsageError& error) {
    throw VaryError(argument, error.what());
  }
}

// A step's (b - a) / h counts as whole within this relative tolerance, so that 0:1:step=0.1
// includes 1 although (1 - 0) / 0.1 is not exactly 10 in floating point.
constexpr double kWholeStepsTolerance = 1e-9;
// More values than this on one axis is refused in the step form (beyond it a double no longer
// counts steps exactly).
constexpr double kMaxStepCount = 9007199254740992.0;  // 2^53

std::string ShortNumber(double value) {
  char text[32];
  const auto result = std::to_chars(text, text + sizeof text, value);
  return std::string(text, result.ptr);
}

// "name=a:b:step=h": a ValueRange from a to the last a + i h <= b (kWholeStepsTolerance).
ValueRange StepRange(std::string_view argument,
                     const ParsedQuantity& a,
                     const ParsedQuantity& b,
                     const ParsedQuantity& h,
                     bool degrees) {
  if (!(h.value > 0.0)) throw VaryError(argument, "the step h of a:b:step=h must be > 0");
  if (!(b.value >= a.value)) throw VaryError(argument, "a:b:step=h needs a <= b");
  // Counted in the unit the axis is shown in, so that 0deg:90deg:step=5deg is exactly 18 steps.
  const auto shown = [&](const ParsedQuantity& q) {
    return degrees ? DisplayDegrees(q.value) : q.value;
  };
  // b/h - a/h where b - a overflows (-1e308:1e308:step=1e308 is three values).
  const double span = shown(b) - shown(a);
  const double steps =
      std::isfinite(span) ? span / shown(h) : shown(b) / shown(h) - shown(a) / shown(h);
  if (!(steps < kMaxStepCount)) throw VaryError(argument, "the step h is too small for a..b");
  const double whole = std::round(steps);
  if (std::abs(steps - whole) <= kWholeStepsTolerance * std::max(1.0, whole)) {
    return {a.value, b.value, static_cast<std::size_t>(whole) + 1};
  }
  const double below = std::floor(steps);
  // The last value lies between a and b; where a + below h overflows on the way, the same sum
  // in halves (scaling by 2 is exact).
  double last = shown(a) + below * shown(h);
  if (!std::isfinite(last)) last = 2.0 * (shown(a) / 2.0 + below * (shown(h) / 2.0));
  return {a.value, degrees ? DegreesToRadians(last) : last, static_cast<std::size_t>(below) + 1};
}

// A bare a:b:n that MATLAB's start:step:end would read otherwise (a, a + b, ..., n).
std::string MatlabWarning(std::string_view argument,
                          std::string_view name,
                          const ParsedQuantity& a,
                          const ParsedQuantity& b,
                          std::size_t n) {
  const double count = static_cast<double>(n);
  if (a.unit_written || b.unit_written) return {};  // "0deg:90deg:5" is not MATLAB's
  if (!(b.value > a.value) || !(count > b.value)) return {};
  const double steps = (count - a.value) / b.value;
  if (steps != std::floor(steps)) return {};
  const std::string first = ShortNumber(a.value), second = ShortNumber(b.value),
                    third = std::to_string(n), label = std::string(name);
  return std::string(argument) + " is read as " + third + " values from " + first + " to " +
         second + " (servokit's a:b:n), not as MATLAB's start:step:end (" + first + ", " +
         ShortNumber(a.value + b.value) + ", ..., " + third + "); write " + label + "=" + first +
         ":" + second + ":n=" + third + " for the first, " + label + "=" + first + ":" + third +
         ":step=" + second + " for the second";
}

}  // namespace

bool IsAngleLike(std::string_view name, DisplayUnit unit) {
  if (unit == DisplayUnit::kDegree) return true;
  std::string lower(name);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const std::string_view angle : {"alpha", "beta", "gamma", "theta", "phi", "psi"}) {
    if (lower == angle) return true;
  }
  return lower.find("angle") != std::string::npos;
}

std::string AngleSpanWarning(std::string_view option,
                             std::string_view name,
                             DisplayUnit unit,
                             bool has_unit,
                             double low,
                             double high) {
  if (has_unit || !IsAngleLike(name, unit)) return {};
  if (!(std::abs(high - low) > 2.0 * std::numbers::pi)) return {};
  return std::string(option) + ": the values of the angle '" + std::string(name) +
         "' carry no unit and span " + ShortNumber(std::abs(high - low)) +
         " rad, more than a full turn (2 pi); they are read as radians (SI): if you meant " +
         "degrees, write them with deg (e.g. 0deg:90deg:n=91)";
}

GridAxis ParseGridAxis(const GridParameters& parameters,
                       std::string_view label,
                       std::string_view text,
                       std::vector<std::string>* warnings) {
  const std::string argument = std::string(label) + " " + std::string(text);
  const std::size_t equals = text.find('=');
  const std::string_view name = TrimBlanks(text.substr(0, equals));
  if (equals == std::string_view::npos || name.empty()) {
    throw VaryError(argument, "expected name=a:b:n or name=v1,v2,... (e.g. " + std::string(label) +
                                  " alpha=0deg:90deg:91)");
  }
  GridAxis axis{std::string(name), VariedParameter(parameters.names, argument, name), {}};
  const DisplayUnit declared = axis.parameter < parameters.units.size()
                                   ? parameters.units[axis.parameter]
                                   : DisplayUnit::kSI;
  const std::string_view spec = text.substr(equals + 1);
  const auto warn = [&](std::string warning) {
    if (warnings && !warning.empty()) warnings->push_back(std::move(warning));
  };
  bool has_unit = false;    // a value in degrees: the axis is shown in degrees
  bool unit_named = false;  // a value that names its unit ("deg" or "rad"): meant as written
  double low = 0.0, high = 0.0;
  if (spec.find(':') != std::string_view::npos) {
    const std::vector<std::string_view> parts = Split(spec, ':');
    if (parts.size() != 3) {
      throw VaryError(argument,
                      "a range is a:b:n, a:b:n=N or a:b:step=h, e.g. alpha=0deg:90deg:n=91 (91 "
                      "values from a to b) or alpha=0deg:90deg:step=1deg");
    }
    // Bare numbers in the unit the model declares (degrees stay degrees: issue #34).
    const ParsedQuantity written_a = ParseValue(argument, parts[0]),
                         written_b = ParseValue(argument, parts[1]);
    const ParsedQuantity a = InDeclaredUnit(written_a, declared),
                         b = InDeclaredUnit(written_b, declared);
    const std::string_view last = TrimBlanks(parts[2]);
    has_unit = a.unit == DisplayUnit::kDegree || b.unit == DisplayUnit::kDegree;
    unit_named = written_a.unit_written || written_b.unit_written;
    if (last.starts_with("step=")) {
      const ParsedQuantity h = InDeclaredUnit(ParseValue(argument, last.substr(5)), declared);
      has_unit = has_unit || h.unit == DisplayUnit::kDegree;
      unit_named = unit_named || h.unit_written;
      axis.display_unit = has_unit ? DisplayUnit::kDegree : declared;
      axis.values = StepRange(argument, a, b, h, axis.display_unit == DisplayUnit::kDegree);
    } else {
      const bool explicit_count = last.starts_with("n=");
      const std::size_t n = ParseCount(argument, explicit_count ? last.substr(2) : last);
      axis.display_unit = has_unit ? DisplayUnit::kDegree : declared;
      axis.values = ValueRange{a.value, b.value, n};
      if (!explicit_count) warn(MatlabWarning(argument, name, written_a, written_b, n));
    }
    low = a.value;
    high = b.value;
  } else {
    std::vector<double> list;
    for (const std::string_view item : Split(spec, ',')) {
      const ParsedQuantity value = InDeclaredUnit(ParseValue(argument, item), declared);
      has_unit = has_unit || value.unit == DisplayUnit::kDegree;
      unit_named = unit_named || value.unit_written;
      list.push_back(value.value);
    }
    low = *std::min_element(list.begin(), list.end());
    high = *std::max_element(list.begin(), list.end());
    axis.display_unit = has_unit ? DisplayUnit::kDegree : declared;
    axis.values = std::move(list);
  }
  warn(AngleSpanWarning(argument, name, declared, has_unit || unit_named, low, high));
  return axis;
}

GridAxis ParseGridAxis(const std::vector<std::string>& parameter_names,
                       std::string_view label,
                       std::string_view text) {
  static const std::vector<DisplayUnit> kNoUnits;
  return ParseGridAxis(GridParameters{parameter_names, kNoUnits}, label, text);
}

ParameterGrid ParseParameterGrid(const std::vector<std::string>& parameter_names,
                                 std::string_view label,
                                 const std::vector<std::string>& texts) {
  static const std::vector<DisplayUnit> kNoUnits;
  return ParseParameterGrid(GridParameters{parameter_names, kNoUnits}, label, texts);
}

ParameterGrid ParseParameterGrid(const GridParameters& parameters,
                                 std::string_view label,
                                 const std::vector<std::string>& texts,
                                 std::vector<std::string>* warnings) {
  std::vector<GridAxis> axes;
  axes.reserve(texts.size());
  for (const std::string& text : texts) {
    axes.push_back(ParseGridAxis(parameters, label, text, warnings));
  }
  // Checked here too, so that the message can say what to do where the texts were written.
  for (std::size_t i = 0; i < axes.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (axes[j].parameter == axes[i].parameter) {
        throw UsageError(std::string(label) + " " + axes[i].name +
                         ": the parameter is varied twice (give all its values in one " +
                         std::string(label) + ")");
      }
    }
  }
  std::optional<ParameterGrid> grid;
  try {
    grid.emplace(std::move(axes));
  } catch (const UsageError& error) {
    throw UsageError(std::string(label) + ": " + std::string(error.what()));  // too many points
  }
  try {
    CheckSweepColumns(*grid);
  } catch (const UsageError& error) {
    throw UsageError(std::string(label) + ": " + std::string(error.what()));
  }
  return std::move(*grid);
}

}  // namespace servokit
