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
//
// Each evaluation finds its knot interval by binary search and the basis there by de Boor's
// recurrence: O(log n + k^2) for n samples, so that a solve costs time linear in the samples.
// (GSL 2.7's gsl_bspline_deriv_eval_nonzero searches the knots from the first, O(n) per call:
// 10^4 samples took 2.9 s, 10^5 over two minutes.)
#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <functional>
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
  /// are from two to kMaxTrajectoryPoints samples, times strictly increasing, every number
  /// finite, 1 <= k <= kMaxContinuousDerivatives, and the spline's derivatives up to order k
  /// finite (samples too close for their values would overflow them).
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
  // The B-spline basis functions nonzero at t (degree + 1 of them) and their derivatives
  // 0..highest into scratch_.basis (function j in row j, order m in column m); returns the
  // index of the first of them.
  Eigen::Index EvaluateBasis(double t, int highest) const;
  // The steps of EvaluateBasis: basis values of every degree at t, then their derivatives.
  void FillBasisTable(double t, Eigen::Index span) const;
  void DifferentiateBasis(int highest) const;
  // The interpolation conditions on the B-spline coefficients, and their right side.
  Eigen::SparseMatrix<double> InterpolationConditions(Eigen::MatrixXd& right_side) const;
  // Knot j of the clamped knot vector: the first time degree + 1 times, each inner time once,
  // the last time degree + 1 times (as gsl_bspline_knots lays them out).
  double Knot(Eigen::Index j) const;
  // Throws UsageError when a derivative up to order k of a spline with coefficients up to
  // `largest_coefficient` could overflow.
  void RequireFiniteDerivatives(double largest_coefficient) const;

  std::vector<double> times_;
  Eigen::MatrixXd values_;
  int continuous_derivatives_;
  int degree_ = 0;                // 2k + 1
  Eigen::MatrixXd coefficients_;  // one row per B-spline basis function, one column per output
  // Evaluation scratch, sized once: a trajectory is read by one solve at a time, never by two
  // threads.
  struct BasisScratch {
    Eigen::MatrixXd basis;        // (degree + 1)^2: function j in row j, order m in column m
    Eigen::MatrixXd table;        // (degree + 1)^2: basis values above, knot spans below
    Eigen::MatrixXd differences;  // 2 x (degree + 1): two rows of derivative coefficients
    Eigen::VectorXd left, right;  // t - knot, knot - t
  };
  mutable BasisScratch scratch_;
};

/// Samples of y_d read from a CSV file: a header line (the first column is the time, each other
/// column one output, in the model's order), then one line of numbers per sample; blank lines
/// and lines starting with '#' are skipped. The values are SI.
struct TrajectorySamples {
  std::vector<double> times;
  Eigen::MatrixXd values;  // one row per time, one column per output
};

/// Reads a samples file. Throws ModelError "file:line: problem" naming the line and column, and
/// at the first sample beyond kMaxTrajectoryPoints, before it is stored.
TrajectorySamples LoadTrajectorySamples(const std::string& path);

/// y_d from a function of the caller's: derivatives(t, highest, d) fills d (outputs x
/// (highest + 1)) with y_d and its derivatives up to `highest` at t. The caller states how many
/// derivatives are continuous and where higher ones jump (at least one time: the start of the
/// motion, where the solve starts by default).
class FunctionTrajectory final : public OutputTrajectory {
 public:
  using DerivativeFunction =
      std::function<void(double t, int highest, Eigen::MatrixXd& derivatives)>;

  /// Throws UsageError unless outputs >= 1, 1 <= continuous_derivatives <=
  /// kMaxContinuousDerivatives and breakpoints holds at least one finite time, in increasing
  /// order.
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
