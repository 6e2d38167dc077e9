#pragma once
// Linear least squares min ||A x - b|| for a matrix A whose rows are banded: each row holds at most
// `bandwidth` consecutive nonzeros, and the rows arrive with their first nonzero column never
// decreasing (a spline's collocation rows, samples in time order). Each row is rotated into the
// banded triangular factor R by Givens rotations as it arrives (Dierckx, "Curve and Surface
// Fitting with Splines", 1993, Sect. 4.1.2, his fpgivs/fprota), so that A is never stored:
// O(bandwidth^2) per row, memory O(columns x bandwidth). Orthogonal, hence no squared condition
// number as with the normal equations. Several right sides share the rotations.
#include <Eigen/Dense>
#include <vector>

namespace servokit {

class BandedLeastSquares {
 public:
  using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  BandedLeastSquares(Eigen::Index columns, int bandwidth, Eigen::Index right_sides);

  /// Adds the row whose entries from column `first` on are row[0 .. bandwidth) (zero beyond the
  /// last column), with right sides right_side[0 .. right_sides). `first` must not decrease from
  /// one row to the next. Both buffers are overwritten (they are the caller's scratch).
  void AddRow(Eigen::Index first, double* row, double* right_side);

  /// The solution x (columns x right sides), or an empty matrix when R has a zero on its
  /// diagonal (the rows do not determine every unknown).
  RowMajorMatrix Solve() const;

  /// Per right side, the sum of the squared residuals of the rows added so far, ||A x - b||^2.
  const Eigen::VectorXd& residual_squares() const { return residual_squares_; }

 private:
  int bandwidth_;
  RowMajorMatrix factor_;   // row j: R(j, j .. j + bandwidth - 1)
  RowMajorMatrix rotated_;  // Q^T b, one row per column of A
  Eigen::VectorXd residual_squares_;
};

}  // namespace servokit
