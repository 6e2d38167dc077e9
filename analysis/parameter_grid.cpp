#include "analysis/parameter_grid.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

#include "base/errors.h"

namespace servokit {
namespace {

// "no parameters", or the names: the message reads "(the model has ...)".
std::string KnownParameters(const std::vector<std::string>& parameter_names) {
  if (parameter_names.empty()) return "no parameters";
  std::string list;
  for (const std::string& name : parameter_names) {
    if (!list.empty()) list += ", ";
    list += name;
  }
  return list;
}

// Value i of `count` values evenly spaced from `first` to `last` (0 < i < count - 1): numpy's
// first + i (last - first) / (count - 1). When last - first overflows (ends of opposite signs
// near the largest double: -1e308:1e308:3), the same point as first (1 - t) + last t with
// t = i / (count - 1), whose two terms are finite and of opposite signs, so that their sum is
// too (0 in the middle of a symmetric range, not inf - inf).
double EvenlySpaced(double first, double last, std::size_t i, std::size_t count) {
  const double intervals = static_cast<double>(count - 1);
  const double span = last - first;
  if (std::isfinite(span)) return first + static_cast<double>(i) * (span / intervals);
  const double t = static_cast<double>(i) / intervals;
  return first * (1.0 - t) + last * t;
}

}  // namespace

std::size_t GridAxis::size() const {
  if (const auto* range = std::get_if<ValueRange>(&values)) return range->count;
  return std::get<std::vector<double>>(values).size();
}

std::string GridAxis::ColumnName() const {
  return display_unit == DisplayUnit::kDegree ? name + "_deg" : name;
}

double GridAxis::DisplayValue(double value) const {
  return display_unit == DisplayUnit::kDegree ? DisplayDegrees(value) : value;
}

double GridAxis::Value(std::size_t i) const {
  assert(i < size());
  if (const auto* list = std::get_if<std::vector<double>>(&values)) return (*list)[i];
  const ValueRange& range = std::get<ValueRange>(values);
  if (i == 0) return range.first;               // also count = 1: first only
  if (i + 1 == range.count) return range.last;  // exact, whatever the rounding of the step
  if (display_unit == DisplayUnit::kDegree) {
    // Evenly spaced in the degrees shown, so that 0deg:90deg:91 holds 1 deg, 2 deg, ... exactly
    // as "1 deg", "2 deg" would be converted, and its table shows 1, 2, ... (An end beyond
    // 1e306 rad has no degree value, and the range is spaced in radians.)
    const double first = DisplayDegrees(range.first), last = DisplayDegrees(range.last);
    if (std::isfinite(first) && std::isfinite(last)) {
      return DegreesToRadians(EvenlySpaced(first, last, i, range.count));
    }
  }
  return EvenlySpaced(range.first, range.last, i, range.count);
}

std::size_t ParameterIndex(const std::vector<std::string>& parameter_names, std::string_view name) {
  const auto found = std::find(parameter_names.begin(), parameter_names.end(), name);
  if (found == parameter_names.end()) {
    throw UsageError("unknown parameter '" + std::string(name) + "' (the model has " +
                     KnownParameters(parameter_names) + ")");
  }
  return static_cast<std::size_t>(found - parameter_names.begin());
}

ParameterGrid::ParameterGrid(std::vector<GridAxis> axes) : axes_(std::move(axes)) {
  for (std::size_t i = 0; i < axes_.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (axes_[j].parameter == axes_[i].parameter) {
        throw UsageError("parameter '" + axes_[i].name + "' is varied twice");
      }
    }
    const std::size_t size = axes_[i].size();
    if (num_points_ > std::numeric_limits<std::size_t>::max() / size) {
      throw UsageError("the grid has more than " +
                       std::to_string(std::numeric_limits<std::size_t>::max()) + " points");
    }
    num_points_ *= size;
  }
  for (const GridAxis& axis : axes_) {
    std::vector<double>& table = values_.emplace_back();
    if (axis.size() > kMostTabulatedValues) continue;
    table.resize(axis.size());
    for (std::size_t i = 0; i < table.size(); ++i) table[i] = axis.Value(i);
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
  ForEachDigit(point, [&](std::size_t k, std::size_t i) { values[k] = Value(k, i); });
}

void ParameterGrid::PointIndices(std::size_t point, std::span<std::size_t> indices) const {
  assert(indices.size() == axes_.size());
  ForEachDigit(point, [&](std::size_t k, std::size_t i) { indices[k] = i; });
}

void ParameterGrid::Apply(std::size_t point, Eigen::VectorXd& parameters) const {
  ForEachDigit(point, [&](std::size_t k, std::size_t i) {
    parameters[static_cast<Eigen::Index>(axes_[k].parameter)] = Value(k, i);
  });
}

}  // namespace servokit
