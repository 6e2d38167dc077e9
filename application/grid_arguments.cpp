#include "application/grid_arguments.h"

#include <charconv>
#include <optional>
#include <system_error>
#include <utility>

#include "models/errors.h"
#include "models/units.h"

namespace servokit {
namespace {

constexpr std::string_view kBlanks = " \t";

std::string_view Trim(std::string_view text) {
  const std::size_t first = text.find_first_not_of(kBlanks);
  if (first == std::string_view::npos) return {};
  const std::size_t last = text.find_last_not_of(kBlanks);
  return text.substr(first, last - first + 1);
}

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

UsageError VaryError(std::string_view text, const std::string& problem) {
  return UsageError("--vary " + std::string(text) + ": " + problem);
}

double ParseValue(std::string_view text, std::string_view item) {
  const std::optional<double> value = ParseQuantity(item);
  if (!value) {
    throw VaryError(
        text, "'" + std::string(Trim(item)) + "' is not a number (use e.g. 0.5 or \"5 deg\")");
  }
  return *value;
}

std::size_t ParseCount(std::string_view text, std::string_view item) {
  const std::string_view digits = Trim(item);
  long long count = 0;
  const char* end = digits.data() + digits.size();
  const auto [stop, error] = std::from_chars(digits.data(), end, count);
  if (digits.empty() || error != std::errc() || stop != end) {
    throw VaryError(text, "'" + std::string(digits) + "' is not a whole number of values");
  }
  if (count < 1) {
    throw VaryError(text, "the number of values must be at least 1, got " + std::to_string(count));
  }
  return static_cast<std::size_t>(count);
}

std::size_t VariedParameter(const std::vector<std::string>& parameter_names,
                            std::string_view text,
                            std::string_view name) {
  try {
    return ParameterIndex(parameter_names, name);
  } catch (const UsageError& error) {
    throw VaryError(text, error.what());
  }
}

}  // namespace

GridAxis ParseGridAxis(const std::vector<std::string>& parameter_names, std::string_view text) {
  const std::size_t equals = text.find('=');
  const std::string_view name = Trim(text.substr(0, equals));
  if (equals == std::string_view::npos || name.empty()) {
    throw VaryError(text,
                    "expected name=a:b:n or name=v1,v2,... (e.g. --vary alpha=0deg:90deg:91)");
  }
  GridAxis axis{std::string(name), VariedParameter(parameter_names, text, name), {}};
  const std::string_view spec = text.substr(equals + 1);
  if (spec.find(':') != std::string_view::npos) {
    const std::vector<std::string_view> parts = Split(spec, ':');
    if (parts.size() != 3) {
      throw VaryError(text, "a range is a:b:n, e.g. alpha=0deg:90deg:91 (n values from a to b)");
    }
    axis.values = ValueRange{ParseValue(text, parts[0]), ParseValue(text, parts[1]),
                             ParseCount(text, parts[2])};
  } else {
    std::vector<double> list;
    for (const std::string_view item : Split(spec, ',')) list.push_back(ParseValue(text, item));
    axis.values = std::move(list);
  }
  return axis;
}

ParameterGrid ParseParameterGrid(const std::vector<std::string>& parameter_names,
                                 const std::vector<std::string>& texts) {
  std::vector<GridAxis> axes;
  axes.reserve(texts.size());
  for (const std::string& text : texts) axes.push_back(ParseGridAxis(parameter_names, text));
  // Checked here too, so that the message can say what to do on the command line.
  for (std::size_t i = 0; i < axes.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (axes[j].parameter == axes[i].parameter) {
        throw UsageError("--vary " + axes[i].name +
                         ": the parameter is varied twice (give all its values in one --vary)");
      }
    }
  }
  try {
    return ParameterGrid(std::move(axes));
  } catch (const UsageError& error) {
    throw UsageError("--vary: " + std::string(error.what()));  // too many points
  }
}

}  // namespace servokit
