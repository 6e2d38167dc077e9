#pragma once
// The parameter points of a sweep (`servokit sweep --vary`, docs/sweep.md "The grid"; the text
// is read by studies/grid_text.h): a full grid over any number of varied parameters. The
// grid is never materialised: a point is addressed by its index and its values are computed from it
// (mixed radix, the first axis varying slowest), so a sweep of 10^8 points needs no more memory
// than one of 10.
#include <Eigen/Dense>
#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "modeling/units.h"

namespace servokit {

/// `count` values evenly spaced from `first` to `last` (SI), both included, as numpy.linspace:
/// value i is first + i (last - first) / (count - 1), and the last one is exactly `last`. Where
/// last - first overflows (-1e308:1e308:3), value i is first (1 - t) + last t, t = i / (count - 1),
/// which cannot (the middle of that range is 0).
/// count = 1 means `first` only. On an axis shown in degrees the spacing is even in degrees
/// (GridAxis::Value).
struct ValueRange {
  double first = 0.0;
  double last = 0.0;
  std::size_t count = 1;
};

/// One varied parameter and the values it takes, in SI units.
struct GridAxis {
  std::string name;
  std::size_t parameter = 0;  // index in the model's parameter_names() (ParameterIndex)
  // A range or an explicit list.
  std::variant<ValueRange, std::vector<double>> values;
  DisplayUnit display_unit = DisplayUnit::kSI;

  /// The table column of the parameter: its name, with "_deg" appended when it is shown in
  /// degrees ("alpha_deg"), so that the unit travels with every table a tool reads.
  std::string ColumnName() const;
  /// `value` (SI) in the unit the parameter is shown in: itself, or DisplayDegrees(value) (the
  /// shortest degree value that converts back to exactly `value`, so that "5 deg" shows as 5).
  double DisplayValue(double value) const;

  /// The number of values (>= 1).
  std::size_t size() const;
  /// Value i (SI), 0 <= i < size(). A range shown in degrees is spaced evenly in degrees, from
  /// DisplayDegrees(first) to DisplayDegrees(last), each value converted with DegreesToRadians,
  /// so that 0deg:90deg:91 takes exactly the values "1 deg", "2 deg", ... would.
  double Value(std::size_t i) const;
};

/// The index of parameter `name` in `parameter_names` (a model's parameter_names()). Throws
/// UsageError "unknown parameter 'name' (the model has a, b, c)".
std::size_t ParameterIndex(const std::vector<std::string>& parameter_names, std::string_view name);

/// The full grid over its axes. Points are numbered 0..num_points()-1 in row-major order: the
/// first axis varies slowest, the last fastest (as nested loops in the order of the axes).
class ParameterGrid {
 public:
  /// Throws UsageError when a parameter is varied twice or the grid has more points than
  /// std::size_t counts. No axes is one point: the model's own parameters.
  explicit ParameterGrid(std::vector<GridAxis> axes);

  const std::vector<GridAxis>& axes() const { return axes_; }
  std::size_t num_points() const { return num_points_; }

  /// The value of each axis at `point`, in the order of axes(); values.size() == axes().size().
  void PointValues(std::size_t point, std::span<double> values) const;
  /// The index of `point`'s value on each axis (axes()[k].Value(indices[k]) is its value);
  /// indices.size() == axes().size().
  void PointIndices(std::size_t point, std::span<std::size_t> indices) const;
  /// Sets the varied entries of `parameters` (indexed as Model::parameter_names()) to `point`'s
  /// values; the other entries are left as they are.
  void Apply(std::size_t point, Eigen::VectorXd& parameters) const;

 private:
  // Calls visit(axis, value index) for each axis, from the last (fastest) to the first.
  template <typename Visit>
  void ForEachDigit(std::size_t point, Visit visit) const;

  // axes_[k].Value(i) at index i, for each axis of at most kMostTabulatedValues values (the
  // others, e.g. a single axis of 10^9 values, are computed point by point): a sweep looks its
  // millions of points' values up instead of computing them again (in degrees for some axes).
  static constexpr std::size_t kMostTabulatedValues = std::size_t{1} << 20;
  double Value(std::size_t axis, std::size_t index) const {
    const std::vector<double>& table = values_[axis];
    return index < table.size() ? table[index] : axes_[axis].Value(index);
  }

  std::vector<GridAxis> axes_;
  std::size_t num_points_ = 1;
  std::vector<std::vector<double>> values_;  // empty for an axis not tabulated
};

}  // namespace servokit
