#include "trajectories/banded_least_squares.h"

#include <cmath>

namespace servokit {

BandedLeastSquares::BandedLeastSquares(Eigen::Index columns,
                                       int bandwidth,
                                       Eigen::Index right_sides)
    : bandwidth_(bandwidth),
      factor_(RowMajorMatrix::Zero(columns, bandwidth)),
      rotated_(RowMajorMatrix::Zero(columns, right_sides)),
      residual_squares_(Eigen::VectorXd::Zero(right_sides)) {}

// Entry i of the row meets row first + i of R, whose entries right of the diagonal are zero
// beyond column first + bandwidth - 1: the rows before it began at or left of `first`. So each
// rotation touches the row's own band only, and the row is used up after `bandwidth` of them;
// what is left of its right side is its residual.
void BandedLeastSquares::AddRow(Eigen::Index first, double* row, double* right_side) {
  const Eigen::Index columns = factor_.rows(), sides = rotated_.cols();
  for (int i = 0; i < bandwidth_ && first + i < columns; ++i) {
    const double pivot = row[i];
    if (pivot == 0.0) continue;
    double* r = factor_.row(first + i).data();
    double* z = rotated_.row(first + i).data();
    const double norm = std::sqrt(r[0] * r[0] + pivot * pivot);
    const double cosine = r[0] / norm, sine = pivot / norm;
    r[0] = norm;
    for (int j = i + 1; j < bandwidth_; ++j) {
      const double upper = r[j - i], lower = row[j];
      r[j - i] = cosine * upper + sine * lower;
      row[j] = cosine * lower - sine * upper;
    }
    for (Eigen::Index side = 0; side < sides; ++side) {
      const double upper = z[side], lower = right_side[side];
      z[side] = cosine * upper + sine * lower;
      right_side[side] = cosine * lower - sine * upper;
    }
  }
  for (Eigen::Index side = 0; side < sides; ++side) {
    residual_squares_(side) += right_side[side] * right_side[side];
  }
}

BandedLeastSquares::RowMajorMatrix BandedLeastSquares::Solve() const {
  const Eigen::Index columns = factor_.rows();
  RowMajorMatrix solution(columns, rotated_.cols());
  for (Eigen::Index j = columns - 1; j >= 0; --j) {
    if (factor_(j, 0) == 0.0) return {};
    Eigen::RowVectorXd sum = rotated_.row(j);
    for (int e = 1; e < bandwidth_ && j + e < columns; ++e) {
      sum -= factor_(j, e) * solution.row(j + e);
    }
    solution.row(j) = sum / factor_(j, 0);
  }
  return solution;
}

}  // namespace servokit
