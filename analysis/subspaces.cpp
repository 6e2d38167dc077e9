#include "analysis/subspaces.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace servokit {
namespace {

// JacobiSVD of a non-square matrix first runs a column-pivoting QR (its "preconditioner"),
// which for the small matrices of analysis/ costs more than the SVD itself. Padding with zero
// rows or columns to a square matrix leaves the singular values (plus zeros) and the singular
// vectors of interest unchanged, and lets the two-sided Jacobi sweep run on its own.
using SquareSvd = Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::NoQRPreconditioner>;

// The square SVDs of this file, one per thread and per function, reused from call to call.
// compute() overwrites everything an earlier call left, so only their memory carries over: the
// several rank decisions of every sweep point then do not allocate JacobiSVD's workspaces (and
// the padded copy) again, which was about a twentieth of a general-path sweep point. These
// functions have no Workspace to keep them in; thread_local keeps sweep threads apart.
enum class SvdUse : std::size_t { kSingularValues, kColumnSpace, kComplement, kNullSpace, kCount };

struct ReusedSvd {
  Eigen::MatrixXd padded;
  SquareSvd svd;
};

ReusedSvd& Reused(SvdUse use) {
  thread_local std::array<ReusedSvd, static_cast<std::size_t>(SvdUse::kCount)> reused;
  return reused[static_cast<std::size_t>(use)];
}

// The SVD of `matrix` padded with zero rows or columns to a square matrix.
const SquareSvd& PaddedSvd(const Eigen::MatrixXd& matrix, unsigned options, SvdUse use) {
  ReusedSvd& reused = Reused(use);
  const Eigen::Index size = std::max(matrix.rows(), matrix.cols());
  reused.padded.setZero(size, size);
  reused.padded.topLeftCorner(matrix.rows(), matrix.cols()) = matrix;
  return reused.svd.compute(reused.padded, options);
}

}  // namespace

Eigen::VectorXd SingularValues(const Eigen::MatrixXd& matrix) {
  if (matrix.rows() == 1 && matrix.cols() == 1 && std::isfinite(matrix(0, 0))) {
    return Eigen::VectorXd::Constant(1, std::abs(matrix(0, 0)));
  }
  // A square matrix needs no QR preconditioner (JacobiSVD runs none on it, but the default one
  // allocates its workspace all the same): the same singular values, to the bit.
  if (matrix.rows() == matrix.cols()) {
    return Reused(SvdUse::kSingularValues).svd.compute(matrix).singularValues();
  }
  return Eigen::JacobiSVD<Eigen::MatrixXd>(matrix).singularValues();
}

Eigen::Index NumericalRank(const Eigen::VectorXd& singular_values, double threshold) {
  Eigen::Index rank = 0;
  while (rank < singular_values.size() && singular_values(rank) > threshold) ++rank;
  return rank;
}

Eigen::MatrixXd ColumnSpaceBasis(const Eigen::MatrixXd& matrix, double threshold) {
  if (matrix.cols() == 0 || matrix.rows() == 0) return Eigen::MatrixXd(matrix.rows(), 0);
  const SquareSvd& svd = PaddedSvd(matrix, Eigen::ComputeFullU, SvdUse::kColumnSpace);
  const Eigen::Index rank = NumericalRank(svd.singularValues(), threshold);
  return svd.matrixU().topLeftCorner(matrix.rows(), rank);
}

Eigen::MatrixXd ComplementBasis(const Eigen::MatrixXd& matrix, double threshold) {
  if (matrix.cols() == 0) return Eigen::MatrixXd::Identity(matrix.rows(), matrix.rows());
  if (matrix.rows() < matrix.cols()) {
    // Zero rows would mix with the complement, so wide matrices keep the QR route.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(matrix, Eigen::ComputeFullU);
    const Eigen::Index rank = NumericalRank(svd.singularValues(), threshold);
    return svd.matrixU().rightCols(matrix.rows() - rank);
  }
  // Zero columns only add zero singular values: U and its complement directions are unchanged.
  const SquareSvd& svd = PaddedSvd(matrix, Eigen::ComputeFullU, SvdUse::kComplement);
  const Eigen::Index rank = NumericalRank(svd.singularValues(), threshold);
  return svd.matrixU().rightCols(matrix.rows() - rank);
}

Eigen::MatrixXd NullSpaceBasis(const Eigen::MatrixXd& matrix, double threshold) {
  if (matrix.rows() == 0) return Eigen::MatrixXd::Identity(matrix.cols(), matrix.cols());
  if (matrix.rows() > matrix.cols()) {
    // Zero columns would mix with the null directions, so tall matrices keep the QR route.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(matrix, Eigen::ComputeFullV);
    const Eigen::Index rank = NumericalRank(svd.singularValues(), threshold);
    return svd.matrixV().rightCols(matrix.cols() - rank);
  }
  // Zero rows only add zero singular values: V and its null directions are unchanged.
  const SquareSvd& svd = PaddedSvd(matrix, Eigen::ComputeFullV, SvdUse::kNullSpace);
  const Eigen::Index rank = NumericalRank(svd.singularValues(), threshold);
  return svd.matrixV().rightCols(matrix.cols() - rank);
}

}  // namespace servokit
