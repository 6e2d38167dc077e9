#pragma once
// Rank decisions and orthonormal bases, in one place so that every analysis decides "zero" the
// same way: a singular value counts as zero when it is at most relative_tolerance * scale,
// where scale is the natural size of the matrix's factors (documented at each call site).
#include <Eigen/Dense>

namespace servokit {

/// Number of singular values above `threshold` (singular values sorted descending).
Eigen::Index NumericalRank(const Eigen::VectorXd& singular_values, double threshold);

/// Orthonormal basis of the column space of `matrix`: the left singular vectors whose singular
/// values exceed `threshold`. Returns a rows x rank matrix (rank may be 0).
Eigen::MatrixXd ColumnSpaceBasis(const Eigen::MatrixXd& matrix, double threshold);

/// Orthonormal basis of the orthogonal complement of the column space of `matrix`: the left
/// singular vectors past the numerical rank. Returns rows x (rows - rank).
Eigen::MatrixXd ComplementBasis(const Eigen::MatrixXd& matrix, double threshold);

/// Orthonormal basis of the null space of `matrix`: the right singular vectors whose singular
/// values are at most `threshold` (and those beyond the row count). Returns cols x nullity.
Eigen::MatrixXd NullSpaceBasis(const Eigen::MatrixXd& matrix, double threshold);

}  // namespace servokit
