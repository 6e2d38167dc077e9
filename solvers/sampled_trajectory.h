#pragma once
// Desired output trajectories given by the user as data, not as a formula of servokit's:
//
//   SampledTrajectory    samples (t_i, y_i) joined by an interpolating spline, at rest before
//                        the first sample and after the last (a sampled motion, a measured
//                        reference, a path planner's output);
//   FunctionTrajectory   a function of the caller's that returns y_d and its derivatives (a
//                        Python callable, a closed form of the user's own).
//
// The inverse reads y_d up to order r = differentiation index - 1 and needs those derivatives
// continuous: the spline has degree 2k + 1 with k = max(4, r), so that k derivatives are
// continuous everywhere, including where it joins the rest before and after it.
#include <gsl/gsl_bspline.h>

#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "solvers/trajectory.h"

namespace servokit {

/// y_d through samples: the interpolating spline of degree 2k + 1 (k = continuous_derivatives)
/// with knots at the sample times and its first k derivatives zero at the first and last
/// sample, held constant before and after them. Between the ends it is 2k times continuously
/// differentiable; with the rest outside, k times. Among such splines it is unique, and it
/// reproduces exactly every polynomial of degree <= 2k + 1 that is at rest to order k at both
/// ends (Eq. 65 sampled at any two or more times gives Eq. 65 back).
class SampledTrajectory final : public OutputTrajectory {
 public:
  /// `values` has one row per sample and one column per output. Throws UsageError unless there
  /// are at least two samples, times strictly increasing, every number finite and k >= 1.
  SampledTrajectory(std::vector<double> times,
                    Eigen::MatrixXd values,
                    int continuous_derivatives = 4);

  Eigen::VectorXd Derivative(double t, int order) const override;
  void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const override;

  Eigen::Index outputs() const override { return values_.cols(); }
  int continuous_derivatives() const override { return continuous_derivatives_; }
  /// The first and last sample: where the spline meets the rest (its derivatives above k jump
  /// there); inside, only its (2k + 1)-th derivative jumps, at every sample.
  std::vector<double> breakpoints() const override { return {times_.front(), times_.back()}; }

 private:
  struct WorkspaceDeleter {
    void operator()(gsl_bspline_workspace* workspace) const { gsl_bspline_free(workspace); }
  };
  struct MatrixDeleter {
    void operator()(gsl_matrix* matrix) const { gsl_matrix_free(matrix); }
  };
  // The B-spline basis at t and its derivatives 0..highest into basis_derivatives_ (GSL),
  // returning the index of the first basis function that is nonzero there.
  std::size_t EvaluateBasis(double t, int highest) const;

  std::vector<double> times_;
  Eigen::MatrixXd values_;
  int continuous_derivatives_;
  Eigen::MatrixXd coefficients_;  // one row per B-spline basis function, one column per output
  // GSL's evaluation scratch: a trajectory is read by one solve at a time, never by two threads.
  std::unique_ptr<gsl_bspline_workspace, WorkspaceDeleter> workspace_;
  std::unique_ptr<gsl_matrix, MatrixDeleter> basis_derivatives_;
};

/// Samples of y_d read from a CSV file: a header line (the first column is the time, each other
/// column one output, in the model's order), then one line of numbers per sample; blank lines
/// and lines starting with '#' are skipped. The values are SI.
struct TrajectorySamples {
  std::vector<double> times;
  Eigen::MatrixXd values;  // one row per time, one column per output
};

/// Reads a samples file. Throws ModelError "file:line: problem" naming the line and column.
TrajectorySamples LoadTrajectorySamples(const std::string& path);

/// y_d from a function of the caller's: derivatives(t, highest, d) fills d (outputs x
/// (highest + 1)) with y_d and its derivatives up to `highest` at t. The caller states how many
/// derivatives are continuous and where higher ones jump (at least one time: the start of the
/// motion, where the solve starts by default).
class FunctionTrajectory final : public OutputTrajectory {
 public:
  using DerivativeFunction =
      std::function<void(double t, int highest, Eigen::MatrixXd& derivatives)>;

  /// Throws UsageError unless outputs >= 1, continuous_derivatives >= 1 and breakpoints holds
  /// at least one finite time, in increasing order.
  FunctionTrajectory(DerivativeFunction derivatives,
                     Eigen::Index outputs,
                     int continuous_derivatives,
                     std::vector<double> breakpoints);

  Eigen::VectorXd Derivative(double t, int order) const override;
  void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const override;

  Eigen::Index outputs() const override { return outputs_; }
  int continuous_derivatives() const override { return continuous_derivatives_; }
  std::vector<double> breakpoints() const override { return breakpoints_; }

 private:
  DerivativeFunction derivatives_;
  Eigen::Index outputs_;
  int continuous_derivatives_;
  std::vector<double> breakpoints_;
};

}  // namespace servokit
