#pragma once
// A structural test that every sparse LU factorisation runs first (issue #29): a matrix with a
// zero column is singular, and Eigen's SparseLU must not see one with too few entries.
#include <Eigen/SparseCore>
#include <optional>

namespace servokit {

/// The first column of `matrix` (0-based) that holds no nonzero value, stored zeros included,
/// or nullopt when every column holds one. A matrix with such a column is singular.
///
/// Why before every Eigen::SparseLU: Eigen 3.4's SparseLU::factorize never returns for an
/// n x n matrix with fewer than n / 20 - 1 stored entries. SparseLUImpl::memInit sizes U for
/// min(20 (nnz + 1) / n, n) n entries, which is 0 then, and retries the allocation of 0 entries
/// in a loop that only a failed allocation ends (measured: M = e1 e1^T factors, and fails
/// cleanly, at n = 40 and hangs at n = 41). A matrix with a value in every column has at least n
/// entries, so that memInit sizes U for at least 20 n.
template <typename Scalar, typename StorageIndex>
std::optional<Eigen::Index> FindZeroColumn(
    const Eigen::SparseMatrix<Scalar, Eigen::ColMajor, StorageIndex>& matrix) {
  using Matrix = Eigen::SparseMatrix<Scalar, Eigen::ColMajor, StorageIndex>;
  for (Eigen::Index column = 0; column < matrix.outerSize(); ++column) {
    bool holds_value = false;
    for (typename Matrix::InnerIterator entry(matrix, column); entry && !holds_value; ++entry) {
      holds_value = entry.value() != Scalar(0);
    }
    if (!holds_value) return column;
  }
  return std::nullopt;
}

}  // namespace servokit
