#pragma once
// Rank decisions and orthonormal bases, in one place so that every analysis decides "zero" the
// same way: a singular value counts as zero when it is at most relative_tolerance * scale,
// where scale is the natural size of the matrix's factors (documented at each call site).
#include <Eigen/Dense>

namespace servokit {

/// The 2-norm of `values` as Eigen's stableNorm() (which scales to avoid overflow and
/// underflow of the squares), at the cost of norm() where the squares can neither overflow nor
/// underflow (the result then agrees with stableNorm() to an ulp); stableNorm() elsewhere.
/// The small analyses of a sweep point ask for dozens of norms.
template <typename Derived>
double SafeNorm(const Eigen::MatrixBase<Derived>& values) {
  const double norm = values.norm();
  if (norm > 1e-140 && norm < 1e140) return norm;
  return values.stableNorm();
}

/// The singular values of `matrix`, descending, as Eigen::JacobiSVD computes them; for a finite
/// 1 x 1 matrix |a| directly, which is JacobiSVD's result to the bit (it scales by |a|, so the
/// work entry is exactly +-1), without its set-up (P and the decoupling matrix of a single-input
/// single-output model, at every sweep point).
Eigen::VectorXd SingularValues(const Eigen::MatrixXd& matrix);

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
