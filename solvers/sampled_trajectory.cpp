#include "solvers/sampled_trajectory.h"

#include <Eigen/Sparse>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <string>
#include <system_error>

#include "files/input_file.h"
#include "models/errors.h"
#include "models/option_check.h"

namespace servokit {
namespace {

void RequireSamples(const std::vector<double>& times, const Eigen::MatrixXd& values) {
  if (times.size() < 2) {
    throw UsageError("samples: " + std::to_string(times.size()) +
                     " sample times; a sampled trajectory needs at least two");
  }
  if (times.size() > kMaxTrajectoryPoints) {
    throw UsageError("samples: " + std::to_string(times.size()) + " samples: at most " +
                     std::to_string(kMaxTrajectoryPoints));
  }
  if (Eigen::Index(times.size()) != values.rows() || values.cols() == 0) {
    throw UsageError("samples: " + std::to_string(times.size()) + " times but " +
                     std::to_string(values.rows()) + " rows of values (one row per time, one " +
                     "column per output)");
  }
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i]) || !values.row(Eigen::Index(i)).allFinite()) {
      throw UsageError("samples: sample " + std::to_string(i) + " is not finite");
    }
    if (i > 0 && !(times[i] > times[i - 1])) {
      throw UsageError("samples: time " + std::to_string(i) + " = " + FormatNumber(times[i]) +
                       " is not after time " + std::to_string(i - 1) + " = " +
                       FormatNumber(times[i - 1]) + " (times must increase strictly)");
    }
  }
}

// The fields of one CSV line (no quoting: the file holds numbers and plain names).
std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields(1);
  for (const char c : line) {
    if (c == ',') {
      fields.emplace_back();
    } else if (c != '\r') {
      fields.back() += c;
    }
  }
  return fields;
}

}  // namespace

TrajectorySamples LoadTrajectorySamples(const std::string& path) {
  std::istringstream file(
      ReadInputFile(path, "the samples file", kTrajectoryFileLimit, ErrorKind::kModel));
  TrajectorySamples samples;
  std::vector<std::vector<double>> rows;
  std::size_t columns = 0;
  std::string line;
  for (std::size_t number = 1; std::getline(file, line); ++number) {
    const auto where = [&] { return path + ":" + std::to_string(number) + ": "; };
    if (line.empty() || line == "\r" || line.front() == '#') continue;
    const std::vector<std::string> fields = SplitFields(line);
    if (columns == 0) {  // the header
      if (fields.size() < 2) {
        throw ModelError(where() +
                         "expected a header t,y1[,y2...]: the time, then one column "
                         "per output");
      }
      columns = fields.size();
      continue;
    }
    if (fields.size() != columns) {
      throw ModelError(where() + std::to_string(fields.size()) + " fields, but the header has " +
                       std::to_string(columns));
    }
    std::vector<double> row;
    for (std::size_t column = 0; column < columns; ++column) {
      const std::string& field = fields[column];
      double value = 0.0;
      const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
      if (error != std::errc() || end != field.data() + field.size() || !std::isfinite(value)) {
        throw ModelError(where() + "column " + std::to_string(column + 1) + ": '" + field +
                         "' is not a finite number");
      }
      row.push_back(value);
    }
    if (rows.size() == kMaxTrajectoryPoints) {
      throw ModelError(where() + "more than " + std::to_string(kMaxTrajectoryPoints) +
                       " samples, the most a trajectory may have");
    }
    rows.push_back(std::move(row));
  }
  if (rows.empty()) throw ModelError(path + ": no samples (a header line, then one line each)");
  samples.values.resize(Eigen::Index(rows.size()), Eigen::Index(columns - 1));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    samples.times.push_back(rows[i][0]);
    for (std::size_t j = 1; j < columns; ++j) {
      samples.values(Eigen::Index(i), Eigen::Index(j - 1)) = rows[i][j];
    }
  }
  return samples;
}

SampledTrajectory::SampledTrajectory(std::vector<double> times,
                                     Eigen::MatrixXd values,
                                     int continuous_derivatives)
    : times_(std::move(times)),
      values_(std::move(values)),
      continuous_derivatives_(continuous_derivatives) {
  RequireSamples(times_, values_);
  RequireContinuousDerivatives("samples", continuous_derivatives);
  degree_ = 2 * continuous_derivatives_ + 1;
  RequireFiniteDerivatives(values_.lpNorm<Eigen::Infinity>());
  const auto order = Eigen::Index(degree_ + 1);
  scratch_.basis.resize(order, order);
  scratch_.table.resize(order, order);
  scratch_.differences.resize(2, order);
  scratch_.left.resize(order);
  scratch_.right.resize(order);
  Eigen::MatrixXd right_side;
  // Built apart, so that its triplets are freed before the factorisation takes its memory.
  const Eigen::SparseMatrix<double> conditions = InterpolationConditions(right_side);
  Eigen::SparseLU<Eigen::SparseMatrix<double>> factor(conditions);
  if (factor.info() == Eigen::Success) coefficients_ = factor.solve(right_side);
  if (factor.info() != Eigen::Success) {
    throw UsageError("samples: no interpolating spline of degree " + std::to_string(degree_) +
                     " through the " + std::to_string(times_.size()) +
                     " samples (the interpolation conditions are singular)");
  }
  RequireFiniteDerivatives(coefficients_.lpNorm<Eigen::Infinity>());
}

// One row per condition: y(t_i) = y_i at every sample, then y^(d) = 0 at the first and the last
// sample for d = 1..k. A derivative row is scaled by h^d (h: the end interval), so that every
// row has entries of order one and the solve keeps its accuracy on any time scale. Over n
// breakpoints the basis of degree 2k + 1 has n + 2k functions, as many as the conditions.
Eigen::SparseMatrix<double> SampledTrajectory::InterpolationConditions(
    Eigen::MatrixXd& right_side) const {
  const int k = continuous_derivatives_;
  const auto samples = Eigen::Index(times_.size());
  const auto order = Eigen::Index(degree_ + 1);
  const Eigen::Index functions = samples + 2 * k;
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(std::size_t(functions * order));
  right_side = Eigen::MatrixXd::Zero(functions, values_.cols());
  Eigen::Index row = 0;
  const auto add_row = [&](double t, int derivative, double scale) {
    const Eigen::Index first = EvaluateBasis(t, derivative);
    for (Eigen::Index j = 0; j < order; ++j) {
      const double entry = scratch_.basis(j, derivative);
      if (entry != 0.0) entries.emplace_back(row, first + j, scale * entry);
    }
    ++row;
  };
  for (Eigen::Index i = 0; i < samples; ++i) {
    right_side.row(row) = values_.row(i);
    add_row(times_[std::size_t(i)], 0, 1.0);
  }
  const double first_interval = times_[1] - times_[0];
  const double last_interval = times_.back() - times_[times_.size() - 2];
  for (int derivative = 1; derivative <= k; ++derivative) {
    add_row(times_.front(), derivative, std::pow(first_interval, derivative));
    add_row(times_.back(), derivative, std::pow(last_interval, derivative));
  }
  Eigen::SparseMatrix<double> conditions(functions, functions);
  conditions.setFromTriplets(entries.begin(), entries.end());
  return conditions;
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
  double bound = largest_coefficient;
  for (int m = 1; m <= continuous_derivatives_ && std::isfinite(bound); ++m) bound *= growth;
  if (std::isfinite(bound)) return;
  throw UsageError("samples: values up to " + FormatNumber(values_.lpNorm<Eigen::Infinity>()) +
                   ", times " + std::to_string(closest - 1) + " = " +
                   FormatNumber(times_[closest - 1]) + " and " + std::to_string(closest) + " = " +
                   FormatNumber(times_[closest]) +
                   " the closest: the spline's derivatives up to order " +
                   std::to_string(continuous_derivatives_) +
                   " overflow (samples too close, or values too large, for doubles)");
}

double SampledTrajectory::Knot(Eigen::Index j) const {
  const Eigen::Index last = Eigen::Index(times_.size()) - 1;
  return times_[std::size_t(std::clamp<Eigen::Index>(j - degree_, 0, last))];
}

// The nonzero B-splines at t and their derivatives by de Boor's recurrence in the form of
// Piegl and Tiller, The NURBS Book (2nd ed., 1997), Algorithm A2.3.
Eigen::Index SampledTrajectory::EvaluateBasis(double t, int highest) const {
  // The interval [t_i, t_i+1) holding t, the last one for t = the last time: O(log n).
  const auto last_interval = std::ptrdiff_t(times_.size()) - 2;
  const std::ptrdiff_t interval = std::clamp<std::ptrdiff_t>(
      std::upper_bound(times_.begin(), times_.end(), t) - times_.begin() - 1, 0, last_interval);
  const Eigen::Index span = interval + degree_;  // in the clamped knot vector
  FillBasisTable(t, span);
  DifferentiateBasis(highest);
  return span - degree_;
}

// The triangle of the basis values of degrees 0..p at t (on and above the diagonal of the
// table, with the knot spans they divide by below it); the last column holds degree p's.
void SampledTrajectory::FillBasisTable(double t, Eigen::Index span) const {
  Eigen::MatrixXd& table = scratch_.table;
  Eigen::VectorXd& left = scratch_.left;
  Eigen::VectorXd& right = scratch_.right;
  table(0, 0) = 1.0;
  for (int j = 1; j <= degree_; ++j) {
    left(j) = t - Knot(span + 1 - j);
    right(j) = Knot(span + j) - t;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      table(j, r) = right(r + 1) + left(j - r);  // a knot span: never 0 (times increase)
      const double ratio = table(r, j - 1) / table(j, r);
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
