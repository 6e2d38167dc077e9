#include "solvers/sampled_trajectory.h"

#include <Eigen/Sparse>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string>
#include <system_error>

#include "models/errors.h"
#include "models/option_check.h"
#include "numerics/gsl_support.h"

namespace servokit {
namespace {

void RequireSamples(const std::vector<double>& times, const Eigen::MatrixXd& values) {
  if (times.size() < 2) {
    throw UsageError("samples: " + std::to_string(times.size()) +
                     " sample times; a sampled trajectory needs at least two");
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
  std::ifstream file(path);
  if (!file) throw ModelError(path + ": cannot open the samples file");
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
  if (continuous_derivatives < 1) {
    throw UsageError("samples: continuous derivatives = " + std::to_string(continuous_derivatives) +
                     ": must be >= 1");
  }
  UseGslStatusCodes();
  const int k = continuous_derivatives_;
  const auto samples = times_.size();
  // GSL counts a spline's order as degree + 1: degree 2k + 1 has order 2k + 2, and the basis
  // over `samples` breakpoints has samples + 2k functions, as many as the conditions below.
  const auto order = std::size_t(2 * k + 2);
  workspace_.reset(gsl_bspline_alloc(order, samples));
  basis_derivatives_.reset(gsl_matrix_alloc(order, order));
  gsl_vector_const_view breakpoints = gsl_vector_const_view_array(times_.data(), samples);
  gsl_bspline_knots(&breakpoints.vector, workspace_.get());
  const auto functions = Eigen::Index(gsl_bspline_ncoeffs(workspace_.get()));

  // One row per condition: y(t_i) = y_i at every sample, then y^(d) = 0 at the first and the
  // last sample for d = 1..k. A derivative row is scaled by h^d (h: the end interval), so that
  // every row has entries of order one and the solve keeps its accuracy on any time scale.
  std::vector<Eigen::Triplet<double>> entries;
  Eigen::MatrixXd right_side = Eigen::MatrixXd::Zero(functions, values_.cols());
  Eigen::Index row = 0;
  const auto add_row = [&](double t, int derivative, double scale) {
    const std::size_t first = EvaluateBasis(t, derivative);
    for (std::size_t j = 0; j < order; ++j) {
      const double entry = gsl_matrix_get(basis_derivatives_.get(), j, std::size_t(derivative));
      if (entry != 0.0) entries.emplace_back(row, Eigen::Index(first + j), scale * entry);
    }
    ++row;
  };
  for (std::size_t i = 0; i < samples; ++i) {
    right_side.row(row) = values_.row(Eigen::Index(i));
    add_row(times_[i], 0, 1.0);
  }
  const double first_interval = times_[1] - times_[0];
  const double last_interval = times_[samples - 1] - times_[samples - 2];
  for (int derivative = 1; derivative <= k; ++derivative) {
    add_row(times_.front(), derivative, std::pow(first_interval, derivative));
    add_row(times_.back(), derivative, std::pow(last_interval, derivative));
  }
  Eigen::SparseMatrix<double> conditions(functions, functions);
  conditions.setFromTriplets(entries.begin(), entries.end());
  Eigen::SparseLU<Eigen::SparseMatrix<double>> factor(conditions);
  if (factor.info() == Eigen::Success) coefficients_ = factor.solve(right_side);
  if (factor.info() != Eigen::Success || !coefficients_.allFinite()) {
    throw UsageError("samples: no interpolating spline of degree " + std::to_string(2 * k + 1) +
                     " through the " + std::to_string(samples) +
                     " samples (the interpolation conditions are singular)");
  }
}

std::size_t SampledTrajectory::EvaluateBasis(double t, int highest) const {
  std::size_t first = 0, last = 0;
  gsl_bspline_deriv_eval_nonzero(t, std::size_t(highest), basis_derivatives_.get(), &first, &last,
                                 workspace_.get());
  return first;
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
  const int degree = 2 * continuous_derivatives_ + 1;
  const int evaluated = std::min(highest, degree);  // higher derivatives of the spline are 0
  const std::size_t first = EvaluateBasis(t, evaluated);
  const auto order = Eigen::Index(degree + 1);
  for (int derivative = 0; derivative <= evaluated; ++derivative) {
    for (Eigen::Index j = 0; j < order; ++j) {
      const double basis =
          gsl_matrix_get(basis_derivatives_.get(), std::size_t(j), std::size_t(derivative));
      derivatives.col(derivative) += basis * coefficients_.row(Eigen::Index(first) + j).transpose();
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
  if (continuous_derivatives_ < 1) {
    throw UsageError("trajectory function: continuous derivatives = " +
                     std::to_string(continuous_derivatives_) + ": must be >= 1");
  }
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
