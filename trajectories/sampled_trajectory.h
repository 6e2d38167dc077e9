#pragma once
// Desired output trajectories given by the user as data, not as a formula of servokit's:
//
//   SampledTrajectory    samples (t_i, y_i) joined by a spline through them (within a relative
//                        1e-10, on as few knots as that allows), at rest before
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
#include <functional>
#include <string>
#include <vector>

#include "trajectories/trajectory.h"

namespace servokit {

/// The default of SampledTrajectory's relative_tolerance: far below any physical meaning and the
/// solvers' tolerances, far above the samples' own rounding (1e-16) and the fit's (1e-14).
constexpr double kSampleTolerance = 1e-10;

/// y_d through samples: a spline of degree 2k + 1 (k = continuous_derivatives) equal to the first
/// and last sample there, its first k derivatives zero there, held constant before and after
/// them. Between the ends it is 2k times continuously differentiable; with the rest outside, k
/// times.
///
/// Its inner knots are every m-th sample time, m = 2^j the largest for which the least-squares
/// spline on those knots has a root-mean-square deviation from the samples of at most
/// relative_tolerance times each output's range (found by bisection on j; the spaces are nested,
/// so the deviation falls as m falls). With m = 1 it is the interpolating spline, which is
/// unique, and relative_tolerance = 0 asks for it. Why not always interpolate: y_d's
/// derivatives, which the inverse reads up to order k, would carry the samples' rounding times
/// (c / h)^k for a sample spacing h (10^5 samples of Eq. 65 written to 17 digits: 3 % of the
/// force, and Radau IIA's step size driven by that noise); on knots m samples apart it is m^k
/// times less. Every polynomial of degree <= 2k + 1 at rest to order k at both ends lies in every
/// such space, so it comes back exactly (Eq. 65 sampled at two or more times gives Eq. 65 back,
/// with no inner knot).
class SampledTrajectory final : public OutputTrajectory {
 public:
  /// `values` has one row per sample and one column per output. Throws UsageError unless there
  /// are from two to kMaxTrajectoryPoints samples, times strictly increasing, every number
  /// finite, 1 <= k <= kMaxContinuousDerivatives, 0 <= relative_tolerance < 1, and the spline's
  /// derivatives up to order k finite (samples too close for their values would overflow them).
  /// Messages begin with `source` (the samples' file, where they came from one).
  SampledTrajectory(std::vector<double> times,
                    Eigen::MatrixXd values,
                    int continuous_derivatives = 4,
                    double relative_tolerance = kSampleTolerance,
                    std::string source = "samples");

  /// The spline's inner knots: every knot_stride()-th sample time (1: it interpolates).
  std::size_t knot_stride() const { return knot_stride_; }
  /// The largest |y_d(t_i) - y_i| over the samples, relative to that output's range.
  double largest_deviation() const { return largest_deviation_; }

  Eigen::VectorXd Derivative(double t, int order) const override;
  void Derivatives(double t, int highest, Eigen::MatrixXd& derivatives) const override;

  Eigen::Index outputs() const override { return values_.cols(); }
  int continuous_derivatives() const override { return continuous_derivatives_; }
  /// The first and last sample: where the spline meets the rest (its derivatives above k jump
  /// there); inside, only its (2k + 1)-th derivative jumps, at every sample.
  std::vector<double> breakpoints() const override { return {times_.front(), times_.back()}; }

 private:
  // Fits the spline on inner knots every `stride` samples (coefficients_, breaks_); returns
  // false when the fit's root-mean-square deviation exceeds `allowed` for some output.
  bool Fit(std::size_t stride, const Eigen::VectorXd& allowed);
  // The largest deviation from the samples relative to `scale`, each output's range.
  double LargestDeviation(const Eigen::VectorXd& scale) const;
  // The B-spline basis functions nonzero at t (degree + 1 of them) and their derivatives
  // 0..highest into scratch_.basis (function j in row j, order m in column m); returns the
  // index of the first of them.
  Eigen::Index EvaluateBasis(double t, int highest) const;
  // The steps of EvaluateBasis: basis values of every degree at t, then their derivatives.
  void FillBasisTable(double t, Eigen::Index span) const;
  void DifferentiateBasis(int highest) const;
  // Knot j of the clamped knot vector: the first break degree + 1 times, each inner break once,
  // the last break degree + 1 times (as gsl_bspline_knots lays them out).
  double Knot(Eigen::Index j) const;
  // Throws UsageError when a derivative up to order k of a spline with coefficients up to
  // `largest_coefficient` could overflow.
  void RequireFiniteDerivatives(double largest_coefficient) const;

  std::string source_;
  std::vector<double> times_;
  Eigen::MatrixXd values_;
  int continuous_derivatives_;
  int degree_ = 0;              // 2k + 1
  std::vector<double> breaks_;  // the first time, the inner knots, the last time
  std::size_t knot_stride_ = 1;
  double largest_deviation_ = 0.0;
  Eigen::MatrixXd coefficients_;  // one row per B-spline basis function, one column per output
  // Evaluation scratch, sized once: a trajectory is read by one solve at a time, never by two
  // threads.
  struct BasisScratch {
    Eigen::MatrixXd basis;  // (degree + 1)^2: function j in row j, order m in column m
    Eigen::MatrixXd table;  // (degree + 1)^2: basis values above, knot spans below
    // The reciprocals of the knot spans of the table, for the span they were formed at: the
    // samples of one knot interval (a fit's rows, a solve's steps) share them.
    Eigen::MatrixXd inverse_spans;
    Eigen::VectorXd knots_below, knots_above;  // knot span + 1 - j and span + j, j = 1..degree
    Eigen::Index span = -1;
    Eigen::MatrixXd differences;  // 2 x (degree + 1): two rows of derivative coefficients
    Eigen::VectorXd left, right;  // t - knot, knot - t
  };
  mutable BasisScratch scratch_;
};

/// Samples of y_d read from a CSV file: a header line, then one line of numbers per sample;
/// blank lines and lines starting with '#' are skipped, blanks around a field are not part of
/// it. The time is the column named t (else the first); a first column with an empty header
/// is an index (pandas' to_csv writes one) and is not read; every other column is one output.
/// The values are SI.
struct TrajectorySamples {
  std::vector<double> times;
  Eigen::MatrixXd values;          // one row per time, one column per output column
  std::vector<std::string> names;  // each output column's header, as written (blanks trimmed)
};

/// Reads a samples file. Throws ModelError "file:line: problem" naming the line and column, and
/// at the first sample beyond kMaxTrajectoryPoints, before it is stored.
TrajectorySamples LoadTrajectorySamples(const std::string& path);

/// The samples' columns for the outputs named `outputs` (the model's y1, y2, ...), in that
/// order: by name when any column is named as an output (y1, or y1_d as `servokit solve`
/// writes it), other columns then left out; by position otherwise. Throws ModelError naming
/// `source` and the output without a column, or the columns when their count does not match.
TrajectorySamples SelectOutputColumns(TrajectorySamples samples,
                                      const std::vector<std::string>& outputs,
                                      const std::string& source);

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
