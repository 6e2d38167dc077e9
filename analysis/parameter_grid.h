#pragma once
// The parameter points of a sweep (DESIGN.md, `servokit sweep --vary`): a full grid over any
// number of varied parameters. The grid is never materialised: a point is addressed by its
// index and its values are computed from it (mixed radix, the first axis varying slowest), so a
// sweep of 10^8 points needs no more memory than one of 10.
#include <Eigen/Dense>
#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "models/model.h"

namespace servokit {

/// `count` values evenly spaced from `first` to `last`, both included, as numpy.linspace:
/// value i is first + i (last - first) / (count - 1), and the last one is exactly `last`.
/// count = 1 means `first` only.
struct ValueRange {
  double first = 0.0;
  double last = 0.0;
  std::size_t count = 1;
};

/// One varied parameter and the values it takes, in SI units.
struct GridAxis {
  std::string name;
  std::size_t parameter = 0;  // index in Model::parameter_names()
  // A range (from "a:b:n") or an explicit list (from "v1,v2,...").
  std::variant<ValueRange, std::vector<double>> values;

  /// The number of values (>= 1).
  std::size_t size() const;
  /// Value i, 0 <= i < size().
  double Value(std::size_t i) const;
};

/// Parses one `--vary` argument: "name=a:b:n" (a range) or "name=v1,v2,..." (a list; one value
/// is a list of one). Each of a, b and v is a number in SI units or "<number> deg" (ParseQuantity),
/// so "alpha=0deg:90deg:91" and "alpha=0 deg:90 deg:91" mean the same; n is a whole number >= 1.
/// Throws UsageError "--vary <text>: ..." naming the problem: bad syntax, unknown parameter (the
/// message lists the known ones), a value that is not a number, n < 1.
GridAxis ParseGridAxis(const Model& model, std::string_view text);
/// The same for any model with these parameter names (a linear model's, say).
GridAxis ParseGridAxis(const std::vector<std::string>& parameter_names, std::string_view text);

/// The full grid over its axes. Points are numbered 0..num_points()-1 in row-major order: the
/// first axis varies slowest, the last fastest (as nested loops in the order of `--vary`).
class ParameterGrid {
 public:
  /// Throws UsageError when a parameter is varied twice or the grid has more points than
  /// std::size_t counts. No axes is one point: the model's own parameters.
  explicit ParameterGrid(std::vector<GridAxis> axes);

  const std::vector<GridAxis>& axes() const { return axes_; }
  std::size_t num_points() const { return num_points_; }

  /// The value of each axis at `point`, in the order of axes(); values.size() == axes().size().
  void PointValues(std::size_t point, std::span<double> values) const;
  /// Sets the varied entries of `parameters` (indexed as Model::parameter_names()) to `point`'s
  /// values; the other entries are left as they are.
  void Apply(std::size_t point, Eigen::VectorXd& parameters) const;

 private:
  // Calls visit(axis, value index) for each axis, from the last (fastest) to the first.
  template <typename Visit>
  void ForEachDigit(std::size_t point, Visit visit) const;

  std::vector<GridAxis> axes_;
  std::size_t num_points_ = 1;
};

/// ParseGridAxis for each text, then the grid over them in the same order.
ParameterGrid ParseParameterGrid(const Model& model, const std::vector<std::string>& texts);
ParameterGrid ParseParameterGrid(const std::vector<std::string>& parameter_names,
                                 const std::vector<std::string>& texts);

}  // namespace servokit
