#include "analysis/parameter_grid.h"

#include <algorithm>
#include <cassert>
#include <charconv>
#include <limits>
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

std::string KnownParameters(const std::vector<std::string>& parameter_names) {
  std::string list;
  for (const std::string& name : parameter_names) {
    if (!list.empty()) list += ", ";
    list += name;
  }
  return list;
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

}  // namespace

std::size_t GridAxis::size() const {
  if (const auto* range = std::get_if<ValueRange>(&values)) return range->count;
  return std::get<std::vector<double>>(values).size();
}

double GridAxis::Value(std::size_t i) const {
  assert(i < size());
  if (const auto* list = std::get_if<std::vector<double>>(&values)) return (*list)[i];
  const ValueRange& range = std::get<ValueRange>(values);
  if (i == 0) return range.first;               // also count = 1: first only
  if (i + 1 == range.count) return range.last;  // exact, whatever the rounding of the step
  const double step = (range.last - range.first) / static_cast<double>(range.count - 1);
  return range.first + static_cast<double>(i) * step;
}

GridAxis ParseGridAxis(const Model& model, std::string_view text) {
  return ParseGridAxis(model.parameter_names(), text);
}

GridAxis ParseGridAxis(const std::vector<std::string>& parameter_names, std::string_view text) {
  const std::size_t equals = text.find('=');
  const std::string_view name = Trim(text.substr(0, equals));
  if (equals == std::string_view::npos || name.empty()) {
    throw VaryError(text,
                    "expected name=a:b:n or name=v1,v2,... (e.g. --vary alpha=0deg:90deg:91)");
  }
  const auto found = std::find(parameter_names.begin(), parameter_names.end(), name);
  if (found == parameter_names.end()) {
    throw VaryError(text, "unknown parameter '" + std::string(name) + "' (the model has " +
                              KnownParameters(parameter_names) + ")");
  }
  GridAxis axis{std::string(name), static_cast<std::size_t>(found - parameter_names.begin()), {}};
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

ParameterGrid::ParameterGrid(std::vector<GridAxis> axes) : axes_(std::move(axes)) {
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (axes_[j].parameter == axes_[i].parameter) {
        throw UsageError("--vary " + axes_[i].name + ": the parameter is varied twice (give all " +
                         "its values in one --vary)");
      }
    }
    const std::size_t size = axes_[i].size();
    if (num_points_ > std::numeric_limits<std::size_t>::max() / size) {
      throw UsageError("--vary: the grid has more than " +
                       std::to_string(std::numeric_limits<std::size_t>::max()) + " points");
    }
    num_points_ *= size;
  }
}

template <typename Visit>
void ParameterGrid::ForEachDigit(std::size_t point, Visit visit) const {
  assert(point < num_points_);
  for (std::size_t k = axes_.size(); k-- > 0;) {
    const std::size_t size = axes_[k].size();
    visit(k, point % size);
    point /= size;
  }
}

void ParameterGrid::PointValues(std::size_t point, std::span<double> values) const {
  assert(values.size() == axes_.size());
  ForEachDigit(point, [&](std::size_t k, std::size_t i) { values[k] = axes_[k].Value(i); });
}

void ParameterGrid::Apply(std::size_t point, Eigen::VectorXd& parameters) const {
  ForEachDigit(point, [&](std::size_t k, std::size_t i) {
    parameters[static_cast<Eigen::Index>(axes_[k].parameter)] = axes_[k].Value(i);
  });
}

ParameterGrid ParseParameterGrid(const Model& model, const std::vector<std::string>& texts) {
  return ParseParameterGrid(model.parameter_names(), texts);
}

ParameterGrid ParseParameterGrid(const std::vector<std::string>& parameter_names,
                                 const std::vector<std::string>& texts) {
  std::vector<GridAxis> axes;
  axes.reserve(texts.size());
  for (const std::string& text : texts) axes.push_back(ParseGridAxis(parameter_names, text));
  return ParameterGrid(std::move(axes));
}

}  // namespace servokit
