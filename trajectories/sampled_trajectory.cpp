#include "trajectories/sampled_trajectory.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

#include "base/errors.h"
#include "base/option_check.h"
#include "base/text.h"
#include "files/input_file.h"
#include "trajectories/banded_least_squares.h"

namespace servokit {
namespace {

void RequireSamples(const std::string& source,
                    const std::vector<double>& times,
                    const Eigen::MatrixXd& values) {
  if (times.size() < 2) {
    throw UsageError(source + ": " + std::to_string(times.size()) +
                     " sample times; a sampled trajectory needs at least two");
  }
  if (times.size() > kMaxTrajectoryPoints) {
    throw UsageError(source + ": " + std::to_string(times.size()) + " samples: at most " +
                     std::to_string(kMaxTrajectoryPoints));
  }
  if (Eigen::Index(times.size()) != values.rows() || values.cols() == 0) {
    throw UsageError(source + ": " + std::to_string(times.size()) + " times but " +
                     std::to_string(values.rows()) + " rows of values (one row per time, one " +
                     "column per output)");
  }
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i]) || !values.row(Eigen::Index(i)).allFinite()) {
      throw UsageError(source + ": sample " + std::to_string(i) + " is not finite");
    }
    if (i > 0 && !(times[i] > times[i - 1])) {
      throw UsageError(source + ": time " + std::to_string(i) + " = " + FormatNumber(times[i]) +
                       " is not after time " + std::to_string(i - 1) + " = " +
                       FormatNumber(times[i - 1]) + " (times must increase strictly)");
    }
  }
}

// A field as a message quotes it: control bytes as \xNN, at most 40 characters, so that a hostile
// file cannot write to the terminal or flood it.
std::string Quoted(std::string_view field) {
  constexpr std::size_t kLongest = 40;
  std::string quoted = "'";
  for (const char c : field.substr(0, kLongest)) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7f) {
      constexpr char kHex[] = "0123456789abcdef";
      quoted += {'\\', 'x', kHex[byte >> 4], kHex[byte & 0xf]};
    } else {
      quoted += c;
    }
  }
  return quoted + (field.size() > kLongest ? "...'" : "'");
}

// The fields of one CSV line (no quoting: the file holds numbers and plain names), views into it.
void SplitFields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  for (std::size_t start = 0;;) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma - start));
    if (comma == std::string_view::npos) return;
    start = comma + 1;
  }
}

}  // namespace

TrajectorySamples LoadTrajectorySamples(const std::string& path) {
  const std::string text =
      ReadInputFile(path, "the samples file", kTrajectoryFileLimit, ErrorKind::kModel);
  std::vector<double> numbers;  // row after row, `columns` each
  std::vector<std::string_view> fields;
  std::vector<std::string> header;
  std::size_t columns = 0, rows = 0;
  std::size_t number = 0;  // of the line
  for (std::size_t start = 0; start < text.size();) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    std::string_view line(text.data() + start, end - start);
    start = end + 1;
    ++number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty() || line.front() == '#') continue;
    const auto where = [&] { return path + ":" + std::to_string(number) + ": "; };
    SplitFields(line, fields);
    for (std::string_view& field : fields) field = TrimBlanks(field);
    if (columns == 0) {  // the header
      if (fields.size() < 2) {
        throw ModelError(where() +
                         "expected a header t,y1[,y2...]: the time, then one column "
                         "per output");
      }
      columns = fields.size();
      header.assign(fields.begin(), fields.end());
      numbers.reserve(std::min(text.size() / (8 * columns), kMaxTrajectoryPoints) * columns);
      continue;
    }
    if (fields.size() != columns) {
      throw ModelError(where() + std::to_string(fields.size()) + " fields, but the header has " +
                       std::to_string(columns));
    }
    if (rows == kMaxTrajectoryPoints) {
      throw ModelError(where() + "more than " + std::to_string(kMaxTrajectoryPoints) +
                       " samples, the most a trajectory may have");
    }
    for (std::size_t column = 0; column < columns; ++column) {
      const std::string_view field = fields[column];
      double value = 0.0;
      const auto [last, error] = std::from_chars(field.data(), field.data() + field.size(), value);
      if (error != std::errc() || last != field.data() + field.size() || !std::isfinite(value)) {
        throw ModelError(where() + "column " + std::to_string(column + 1) + ": " + Quoted(field) +
                         " is not a finite number");
      }
      numbers.push_back(value);
    }
    ++rows;
  }
  if (rows == 0) throw ModelError(path + ": no samples (a header line, then one line each)");
  // An unnamed first column is an index; the time is the column named t, else the first other.
  const std::size_t first = header.front().empty() ? 1 : 0;
  const auto named_time = std::find(header.begin() + std::ptrdiff_t(first), header.end(), "t");
  const std::size_t time =
      named_time == header.end() ? first : std::size_t(named_time - header.begin());
  if (columns - first < 2) {
    throw ModelError(path + ": expected the time and at least one output after the index column");
  }
  TrajectorySamples samples;
  samples.times.resize(rows);
  samples.values.resize(Eigen::Index(rows), Eigen::Index(columns - first - 1));
  for (std::size_t j = first; j < columns; ++j) {
    if (j != time) samples.names.push_back(header[j]);
  }
  for (std::size_t i = 0; i < rows; ++i) {
    samples.times[i] = numbers[i * columns + time];
    Eigen::Index output = 0;
    for (std::size_t j = first; j < columns; ++j) {
      if (j != time) samples.values(Eigen::Index(i), output++) = numbers[i * columns + j];
    }
  }
  return samples;
}

TrajectorySamples SelectOutputColumns(TrajectorySamples samples,
                                      const std::vector<std::string>& outputs,
                                      const std::string& source) {
  const auto column_of = [&](const std::string& output) -> std::optional<std::size_t> {
    for (const std::string& name : {output, output + "_d"}) {
      const auto found = std::find(samples.names.begin(), samples.names.end(), name);
      if (found != samples.names.end()) return std::size_t(found - samples.names.begin());
    }
    return std::nullopt;
  };
  const bool by_name = std::any_of(outputs.begin(), outputs.end(),
                                   [&](const std::string& output) { return column_of(output); });
  std::string columns;
  for (const std::string& name : samples.names) columns += (columns.empty() ? "" : ", ") + name;
  if (!by_name) {
    if (samples.names.size() != outputs.size()) {
      throw ModelError(source + ": " + std::to_string(samples.names.size()) +
                       " output columns after t (" + Quoted(columns) + "), but the model has " +
                       std::to_string(outputs.size()) + " (name them as its outputs: y1, ...)");
    }
    return samples;  // by position
  }
  // A column named as an output the model lacks (y2 of a one-output model) is a sign of the
  // wrong model or file, not a column to leave out.
  for (const std::string& name : samples.names) {
    const std::string_view output =
        name.ends_with("_d") ? std::string_view(name).substr(0, name.size() - 2) : name;
    const bool output_like =
        output.size() > 1 && output.front() == 'y' &&
        std::all_of(output.begin() + 1, output.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (output_like && std::find(outputs.begin(), outputs.end(), output) == outputs.end()) {
      throw ModelError(source + ": column " + Quoted(name) +
                       " names an output the model does not have (it has " +
                       std::to_string(outputs.size()) +
                       (outputs.size() == 1 ? " output" : " outputs") + ")");
    }
  }
  TrajectorySamples selected;
  selected.times = std::move(samples.times);
  selected.values.resize(samples.values.rows(), Eigen::Index(outputs.size()));
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const std::optional<std::size_t> column = column_of(outputs[i]);
    if (!column) {
      throw ModelError(source + ": no column " + outputs[i] + " (or " + outputs[i] + "_d) among " +
                       Quoted(columns));
    }
    selected.values.col(Eigen::Index(i)) = samples.values.col(Eigen::Index(*column));
    selected.names.push_back(samples.names[*column]);
  }
  return selected;
}

SampledTrajectory::SampledTrajectory(std::vector<double> times,
                                     Eigen::MatrixXd values,
                                     int continuous_derivatives,
                                     double relative_tolerance,
                                     std::string source)
    : source_(std::move(source)),
      times_(std::move(times)),
      values_(std::move(values)),
      continuous_derivatives_(continuous_derivatives) {
  RequireSamples(source_, times_, values_);
  RequireContinuousDerivatives(source_, continuous_derivatives);
  RequireOption(relative_tolerance >= 0.0 && relative_tolerance < 1.0, "SampledTrajectory",
                "relative_tolerance", relative_tolerance, "must be >= 0 (0: interpolate) and < 1");
  degree_ = 2 * continuous_derivatives_ + 1;
  RequireFiniteDerivatives(values_.lpNorm<Eigen::Infinity>());
  const auto order = Eigen::Index(degree_ + 1);
  scratch_.basis.resize(order, order);
  scratch_.table.resize(order, order);
  scratch_.inverse_spans.resize(order, order);
  scratch_.knots_below.resize(order);
  scratch_.knots_above.resize(order);
  scratch_.differences.resize(2, order);
  scratch_.left.resize(order);
  scratch_.right.resize(order);
  // Each output's range, the scale of its tolerance (its largest value for a constant one).
  Eigen::VectorXd scale = values_.colwise().maxCoeff() - values_.colwise().minCoeff();
  for (Eigen::Index output = 0; output < scale.size(); ++output) {
    if (scale(output) == 0.0) scale(output) = values_.col(output).cwiseAbs().maxCoeff();
  }
  const Eigen::VectorXd allowed = relative_tolerance * scale;
  // Bisection on j for the stride 2^j, between 0 (interpolation, always taken) and the first
  // stride past the last sample (no inner knot), which smooth samples pass at once.
  int passes = 0, fails = 0;
  while ((std::size_t(1) << fails) < times_.size() - 1) ++fails;
  if (relative_tolerance > 0.0 && Fit(std::size_t(1) << fails, allowed)) {
    passes = fails;
  } else if (relative_tolerance > 0.0) {
    while (fails - passes > 1) {
      const int middle = (passes + fails) / 2;
      (Fit(std::size_t(1) << middle, allowed) ? passes : fails) = middle;
    }
  }
  const std::size_t stride = std::size_t(1) << passes;
  if (knot_stride_ != stride || coefficients_.size() == 0) {
    Fit(stride, Eigen::VectorXd::Constant(allowed.size(), INFINITY));
  }
  if (coefficients_.size() == 0) {
    throw UsageError(source_ + ": no interpolating spline of degree " + std::to_string(degree_) +
                     " through the " + std::to_string(times_.size()) +
                     " samples (the interpolation conditions are singular)");
  }
  RequireFiniteDerivatives(coefficients_.lpNorm<Eigen::Infinity>());
  largest_deviation_ = LargestDeviation(scale);
}

// The coefficients of the basis functions that meet the ends are fixed: the first k + 1 equal
// the first sample (then the spline's value there is that sample and its first k derivatives
// are zero: on a clamped knot vector the d-th derivative at the end is a combination of the
// first d + 1 coefficients' differences), the last k + 1 the last sample. The rest, one per inner
// knot, are the least-squares solution over the inner samples.
bool SampledTrajectory::Fit(std::size_t stride, const Eigen::VectorXd& allowed) {
  const int k = continuous_derivatives_;
  const std::size_t samples = times_.size();
  breaks_.assign(1, times_.front());
  for (std::size_t i = stride; i < samples - 1; i += stride) breaks_.push_back(times_[i]);
  breaks_.push_back(times_.back());
  knot_stride_ = stride;
  scratch_.span = -1;  // the knots moved
  const auto functions = Eigen::Index(breaks_.size()) + degree_ - 1;
  const Eigen::Index unknowns = functions - 2 * (k + 1);  // the inner knots
  const Eigen::Index outputs = values_.cols();
  const Eigen::RowVectorXd first_value = values_.row(0), last_value = values_.bottomRows(1);
  BandedLeastSquares fit(unknowns, degree_ + 1, outputs);
  std::vector<double> row(std::size_t(degree_ + 1));
  Eigen::RowVectorXd right_side(outputs);
  for (std::size_t i = 1; i + 1 < samples; ++i) {
    const Eigen::Index first = EvaluateBasis(times_[i], 0);
    const Eigen::Index first_unknown = std::max<Eigen::Index>(first - (k + 1), 0);
    right_side = values_.row(Eigen::Index(i));
    std::fill(row.begin(), row.end(), 0.0);
    for (Eigen::Index j = 0; j <= degree_; ++j) {
      const Eigen::Index function = first + j;
      const double basis = scratch_.basis(j, 0);
      if (function <= k) {
        right_side -= basis * first_value;
      } else if (function >= functions - (k + 1)) {
        right_side -= basis * last_value;
      } else {
        row[std::size_t(function - (k + 1) - first_unknown)] = basis;
      }
    }
    fit.AddRow(first_unknown, row.data(), right_side.data());
  }
  const BandedLeastSquares::RowMajorMatrix inner = fit.Solve();
  if (inner.rows() != unknowns || !inner.allFinite()) {
    coefficients_.resize(0, 0);
    return false;
  }
  coefficients_.resize(functions, outputs);
  coefficients_.topRows(k + 1).rowwise() = first_value;
  coefficients_.middleRows(k + 1, unknowns) = inner;
  coefficients_.bottomRows(k + 1).rowwise() = last_value;
  const auto rows = double(std::max<std::size_t>(samples - 2, 1));
  return ((fit.residual_squares() / rows).cwiseSqrt().array() <= allowed.array()).all();
}

double SampledTrajectory::LargestDeviation(const Eigen::VectorXd& scale) const {
  double largest = 0.0;
  Eigen::MatrixXd value;
  for (std::size_t i = 1; i + 1 < times_.size(); ++i) {
    Derivatives(times_[i], 0, value);
    const Eigen::ArrayXd deviation =
        (value.col(0) - values_.row(Eigen::Index(i)).transpose()).cwiseAbs().array() /
        scale.array().max(std::numeric_limits<double>::min());
    largest = std::max(largest, deviation.maxCoeff());
  }
  return largest;
}

// The derivative of order m of a spline of degree p is a spline of degree p - m whose
// coefficients are differences of its own divided by knot spans over at most p intervals
// (de Boor), each step at most 2 (p - m) / h_min times larger: |y^(m)| <= max |c| (2p / h_min)^m.
// With that bound finite for m <= k, every derivative the solvers read is finite. Checked with
// the values for c before the solve (whose end rows, scaled by h^d, vanish for a tiny h) and
// with the coefficients after it.
void SampledTrajectory::RequireFiniteDerivatives(double largest_coefficient) const {
  std::size_t closest = 1;
  for (std::size_t i = 2; i < times_.size(); ++i) {
    if (times_[i] - times_[i - 1] < times_[closest] - times_[closest - 1]) closest = i;
  }
  const double growth = 2.0 * degree_ / (times_[closest] - times_[closest - 1]);
  // At least 1: the basis functions' derivatives, (2p / h)^m, must be finite on their own, or
  // zero values would give 0 * inf = NaN.
  double bound = std::max(largest_coefficient, 1.0);
  for (int m = 1; m <= continuous_derivatives_ && std::isfinite(bound); ++m) bound *= growth;
  if (std::isfinite(bound)) return;
  throw UsageError(source_ + ": values up to " + FormatNumber(values_.lpNorm<Eigen::Infinity>()) +
                   ", times " + std::to_string(closest - 1) + " = " +
                   FormatNumber(times_[closest - 1]) + " and " + std::to_string(closest) + " = " +
                   FormatNumber(times_[closest]) +
                   " the closest: the spline's derivatives up to order " +
                   std::to_string(continuous_derivatives_) +
                   " overflow (samples too close, or values too large, for doubles)");
}

double SampledTrajectory::Knot(Eigen::Index j) const {
  const Eigen::Index last = Eigen::Index(breaks_.size()) - 1;
  return breaks_[std::size_t(std::clamp<Eigen::Index>(j - degree_, 0, last))];
}

// The nonzero B-splines at t and their derivatives by de Boor's recurrence in the form of
// Piegl and Tiller, The NURBS Book (2nd ed., 1997), Algorithm A2.3.
Eigen::Index SampledTrajectory::EvaluateBasis(double t, int highest) const {
  // The interval [t_i, t_i+1) holding t, the last one for t = the last time: O(log n).
  const auto last_interval = std::ptrdiff_t(breaks_.size()) - 2;
  const std::ptrdiff_t interval = std::clamp<std::ptrdiff_t>(
      std::upper_bound(breaks_.begin(), breaks_.end(), t) - breaks_.begin() - 1, 0, last_interval);
  const Eigen::Index span = interval + degree_;  // in the clamped knot vector
  FillBasisTable(t, span);
  DifferentiateBasis(highest);
  return span - degree_;
}

// The triangle of the basis values of degrees 0..p at t (on and above the diagonal of the
// table, with the knot spans they divide by below it); the last column holds degree p's.
void SampledTrajectory::FillBasisTable(double t, Eigen::Index span) const {
  Eigen::MatrixXd& table = scratch_.table;
  Eigen::MatrixXd& inverse = scratch_.inverse_spans;
  Eigen::VectorXd& left = scratch_.left;
  Eigen::VectorXd& right = scratch_.right;
  Eigen::VectorXd& below = scratch_.knots_below;
  Eigen::VectorXd& above = scratch_.knots_above;
  if (scratch_.span != span) {
    for (int j = 1; j <= degree_; ++j) {
      below(j) = Knot(span + 1 - j);
      above(j) = Knot(span + j);
    }
    for (int j = 1; j <= degree_; ++j) {
      for (int r = 0; r < j; ++r) {
        table(j, r) = Knot(span + r + 1) - Knot(span + 1 - j + r);  // never 0 (times increase)
        inverse(j, r) = 1.0 / table(j, r);
      }
    }
    scratch_.span = span;
  }
  table(0, 0) = 1.0;
  for (int j = 1; j <= degree_; ++j) {
    left(j) = t - below(j);
    right(j) = above(j) - t;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const double ratio = table(r, j - 1) * inverse(j, r);
      table(r, j) = saved + right(r + 1) * ratio;
      saved = left(j - r) * ratio;
    }
    table(j, j) = saved;
  }
}

// Column m of scratch_.basis: the m-th derivatives of the p + 1 functions, each from the
// differences of the coefficients of its lower-degree pieces (two rows, the previous order's
// and this one's), times p! / (p - m)!.
void SampledTrajectory::DifferentiateBasis(int highest) const {
  const int p = degree_;
  const Eigen::MatrixXd& table = scratch_.table;
  Eigen::MatrixXd& basis = scratch_.basis;
  Eigen::MatrixXd& a = scratch_.differences;
  for (int j = 0; j <= p; ++j) basis(j, 0) = table(j, p);
  if (highest == 0) return;
  for (int r = 0; r <= p; ++r) {
    Eigen::Index current = 0, next = 1;
    a(0, 0) = 1.0;
    for (int m = 1; m <= highest; ++m) {
      double derivative = 0.0;
      const int rm = r - m, pm = p - m;
      if (r >= m) {
        a(next, 0) = a(current, 0) / table(pm + 1, rm);
        derivative = a(next, 0) * table(rm, pm);
      }
      const int first = rm >= -1 ? 1 : -rm;
      const int last = r - 1 <= pm ? m - 1 : p - r;
      for (int j = first; j <= last; ++j) {
        a(next, j) = (a(current, j) - a(current, j - 1)) / table(pm + 1, rm + j);
        derivative += a(next, j) * table(rm + j, pm);
      }
      if (r <= pm) {
        a(next, m) = -a(current, m - 1) / table(pm + 1, r);
        derivative += a(next, m) * table(r, pm);
      }
      basis(r, m) = derivative;
      std::swap(current, next);
    }
  }
  double factor = p;  // p! / (p - m)!
  for (int m = 1; m <= highest; ++m) {
    basis.col(m).head(p + 1) *= factor;
    factor *= p - m;
  }
}

Eigen::VectorXd SampledTrajectory::Derivative(double t, int order) const {
  Eigen::MatrixXd derivatives;
  Derivatives(t, order, derivatives);
  return derivatives.col(order);
}

void SampledTrajectory::Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const {
  if (derivatives.rows() != outputs() || derivatives.cols() != highest + 1) {
    derivatives.resize(outputs(), highest + 1);
  }
  derivatives.setZero();
  // At rest outside the samples: the first value before them, the last after them.
  if (t < times_.front() || t > times_.back()) {
    derivatives.col(0) = values_.row(t < times_.front() ? 0 : values_.rows() - 1).transpose();
    return;
  }
  const int evaluated = std::min(highest, degree_);  // higher derivatives of the spline are 0
  const Eigen::Index first = EvaluateBasis(t, evaluated);
  const auto order = Eigen::Index(degree_ + 1);
  for (int derivative = 0; derivative <= evaluated; ++derivative) {
    for (Eigen::Index j = 0; j < order; ++j) {
      derivatives.col(derivative) +=
          scratch_.basis(j, derivative) * coefficients_.row(first + j).transpose();
    }
  }
  // At the first and last sample the spline meets the rest: its value is the sample's and its
  // first k derivatives are zero by construction, exactly, not to the round-off of the solve
  // (a solve that starts there tests for rest at 1e-14). Higher orders come from inside.
  if (t == times_.front() || t == times_.back()) {
    derivatives.col(0) = values_.row(t == times_.front() ? 0 : values_.rows() - 1).transpose();
    derivatives.middleCols(1, std::min(highest, continuous_derivatives_)).setZero();
  }
}

FunctionTrajectory::FunctionTrajectory(DerivativeFunction derivatives,
                                       Eigen::Index outputs,
                                       int continuous_derivatives,
                                       std::vector<double> breakpoints)
    : derivatives_(std::move(derivatives)),
      outputs_(outputs),
      continuous_derivatives_(continuous_derivatives),
      breakpoints_(std::move(breakpoints)) {
  if (outputs_ < 1) throw UsageError("trajectory function: it must give at least one output");
  RequireContinuousDerivatives("trajectory function", continuous_derivatives_);
  if (breakpoints_.empty() ||
      !std::all_of(breakpoints_.begin(), breakpoints_.end(),
                   [](double t) { return std::isfinite(t); }) ||
      !std::is_sorted(breakpoints_.begin(), breakpoints_.end())) {
    throw UsageError(
        "trajectory function: breakpoints must hold at least one time (the start of the "
        "motion), finite and in increasing order");
  }
}

Eigen::VectorXd FunctionTrajectory::Derivative(double t, int order) const {
  Eigen::MatrixXd derivatives;
  Derivatives(t, order, derivatives);
  return derivatives.col(order);
}

void FunctionTrajectory::Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const {
  derivatives.resize(outputs_, highest + 1);
  derivatives_(t, highest, derivatives);
  // A function that gives the wrong shape cannot throw through the integrators' C callbacks:
  // NaN makes the solve stop at once, and the caller reports why (e.g. the Python module).
  if (derivatives.rows() != outputs_ || derivatives.cols() != highest + 1) {
    derivatives.setConstant(outputs_, highest + 1, std::nan(""));
  }
}

}  // namespace servokit
