#include "analysis/linear_zero_dynamics.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <utility>

#include "base/errors.h"
#include "base/number_format.h"
#include "base/option_check.h"
#include "numerics/sparse_structure.h"

namespace servokit {
namespace {

constexpr std::pair<RosenbrockFactorization, std::string_view> kFactorizationNames[] = {
    {RosenbrockFactorization::kNone, "none"},
    {RosenbrockFactorization::kSymmetricSchur, "symmetric-schur"},
    {RosenbrockFactorization::kSchur, "schur"},
    {RosenbrockFactorization::kBorderedLU, "bordered-lu"},
};

// Power iterations for the size of the largest |nu| (the scale of the infinite-eigenvalue test
// of the rightmost route): a few dozen give it within a factor of a few, which is all a scale for
// a 1e-6 threshold needs.
constexpr int kScaleIterations = 30;

// The starting vector of ARPACK and of the power iteration: a fixed pseudo-random vector (so
// that runs are reproducible), mapped once by OP so that it lies in the range of OP and carries
// no component along the index-1 infinite eigenvectors.
constexpr unsigned kStartSeed = 20130613u;

// A matrix's shape as a message writes it: "3 x 2".
std::string ShapeText(const SparseMatrix& matrix) {
  return std::to_string(matrix.rows()) + " x " + std::to_string(matrix.cols());
}

void RequireShape(const char* field,
                  const SparseMatrix& matrix,
                  Eigen::Index rows,
                  Eigen::Index cols) {
  RequireOption(matrix.rows() == rows && matrix.cols() == cols, "LinearSystem", field,
                ShapeText(matrix),
                "must be " + std::to_string(rows) + " x " + std::to_string(cols));
}

bool SamePattern(const SparseMatrix& a, const SparseMatrix& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols() || a.nonZeros() != b.nonZeros()) return false;
  return std::equal(a.outerIndexPtr(), a.outerIndexPtr() + a.outerSize() + 1, b.outerIndexPtr()) &&
         std::equal(a.innerIndexPtr(), a.innerIndexPtr() + a.nonZeros(), b.innerIndexPtr());
}

std::string Count(Eigen::Index count) { return std::to_string(count); }

// Q(sigma) counts as symmetric (LDLT) when |Q - Q^T| <= kSymmetryTolerance max |Q| entrywise:
// round-off of a symmetric model's file, no more (LDLT reads the lower triangle only).
constexpr double kSymmetryTolerance = 64 * std::numeric_limits<double>::epsilon();

bool IsSymmetric(const SparseMatrix& matrix) {
  if (matrix.rows() != matrix.cols()) return false;
  if (matrix.nonZeros() == 0) return true;
  const double limit = kSymmetryTolerance * matrix.coeffs().cwiseAbs().maxCoeff();
  const SparseMatrix transpose = matrix.transpose();
  if (SamePattern(matrix, transpose)) {  // the usual case: compare the values in place
    return ((matrix.coeffs() - transpose.coeffs()).cwiseAbs() <= limit).all();
  }
  const SparseMatrix asymmetry = matrix - transpose;
  return asymmetry.nonZeros() == 0 || asymmetry.coeffs().cwiseAbs().maxCoeff() <= limit;
}

// Row i: sum over j of |a_ij| (the infinity norm of A is the largest).
Eigen::VectorXd AbsoluteRowSums(const SparseMatrix& matrix) {
  Eigen::VectorXd sums = Eigen::VectorXd::Zero(matrix.rows());
  for (Eigen::Index j = 0; j < matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(matrix, j); it; ++it)
      sums(it.row()) += std::abs(it.value());
  }
  return sums;
}

std::string SingularRosenbrockMessage(double shift, const std::string& detail) {
  return "the Rosenbrock matrix [[-(K + s D + s^2 M), B], [C, 0]] is singular at the shift s = " +
         FormatSignificant(shift, 6) +
         " (s is an invariant zero, or the model is not invertible): " + detail +
         "; choose another shift";
}

// nu of the dense OP, 2n x 2n, all eigenvalues. Without eigenvectors, which would double the
// cost: the error bounds take each kept zero's vector from ZeroNullVector, O(n) each.
Eigen::VectorXcd DenseOperatorEigenvalues(const LinearSystem& system,
                                          const LinearZeroDynamicsWorkspace& workspace) {
  const Eigen::Index n = system.dof();
  const Eigen::Index size = 2 * n;
  Eigen::MatrixXd op(size, size);
  Eigen::VectorXd unit = Eigen::VectorXd::Zero(size);
  for (Eigen::Index j = 0; j < size; ++j) {
    unit(j) = 1.0;
    workspace.ApplyShiftInvert(unit.data(), op.col(j).data());
    unit(j) = 0.0;
  }
  const Eigen::EigenSolver<Eigen::MatrixXd> eigen(op, false);
  if (eigen.info() != Eigen::Success) {
    throw NoSolution("the eigenvalues of the shift-inverted Rosenbrock operator did not converge");
  }
  return eigen.eigenvalues();
}

// The indices of the nu that belong to finite zeros (lambda = shift + 1/nu), largest |nu|
// first: the zero_count largest in magnitude when known, else those above
// infinite_tolerance * max |nu|.
std::vector<std::size_t> FiniteZeroIndices(const std::vector<std::complex<double>>& nus,
                                           Eigen::Index zero_count,
                                           double scale,
                                           const LinearZeroDynamicsOptions& options) {
  std::vector<std::size_t> order(nus.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&nus](std::size_t a, std::size_t b) {
    return std::abs(nus[a]) > std::abs(nus[b]);
  });
  if (zero_count >= 0 && std::size_t(zero_count) < order.size()) {
    order.resize(std::size_t(zero_count));
  }
  for (const std::size_t i : order) scale = std::max(scale, std::abs(nus[i]));
  std::vector<std::size_t> kept;
  for (const std::size_t i : order) {
    if (zero_count < 0 && std::abs(nus[i]) <= options.infinite_tolerance * scale) continue;
    if (nus[i] == 0.0) continue;
    kept.push_back(i);
  }
  return kept;
}

Eigen::VectorXd StartVector(const LinearZeroDynamicsWorkspace& workspace, Eigen::Index size) {
  std::mt19937 generator(kStartSeed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXd random(size);
  for (Eigen::Index i = 0; i < size; ++i) random(i) = uniform(generator);
  Eigen::VectorXd start(size);
  workspace.ApplyShiftInvert(random.data(), start.data());
  const double norm = start.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) {
    throw NoSolution("the shift-inverted Rosenbrock operator maps a random vector to " +
                     std::string(norm > 0.0 ? "a non-finite one" : "zero"));
  }
  return start / norm;
}

double EstimateLargestMagnitude(const LinearZeroDynamicsWorkspace& workspace,
                                Eigen::VectorXd vector) {
  Eigen::VectorXd image(vector.size());
  double estimate = 0.0;
  for (int i = 0; i < kScaleIterations; ++i) {
    workspace.ApplyShiftInvert(vector.data(), image.data());
    estimate = image.norm();
    if (!(estimate > 0.0)) break;
    vector = image / estimate;
  }
  return estimate;
}

std::string Scope(const LinearZeroDynamics& result, Eigen::Index computed) {
  const std::string solver = result.solver_used == LinearEigenSolver::kDense ? "dense" : "ARPACK";
  if (result.complete) return "all " + Count(computed) + " zeros (" + solver + ")";
  const std::string of =
      result.zero_count >= 0 ? " of " + Count(result.zero_count) : " (total unknown)";
  if (result.target == EigenvalueTarget::kNearest) {
    return "the " + Count(computed) + " zeros nearest " + FormatSignificant(result.shift, 6) + of +
           " (ARPACK shift-invert); stability and modes of these only";
  }
  return "the " + Count(computed) + " zeros with largest Re 1/(lambda - " +
         FormatSignificant(result.shift, 6) + ")" + of +
         " (ARPACK shift-invert): every zero with Re lambda > " +
         FormatSignificant(result.shift, 6) + " ranks first";
}

// The safety factor of the per-zero error bound (ZeroErrorBounds): LU growth and the
// conditioning the one-sided estimate does not see. 10 keeps the bound above every error
// measured against the chain's closed form (N = 1e3 .. 1e6: the error of Re lambda at most 0.1
// of the bound).
constexpr double kErrorBoundSafety = 10.0;

double InfinityNorm(const SparseMatrix& matrix) {
  Eigen::VectorXd row_sums = Eigen::VectorXd::Zero(matrix.rows());
  for (Eigen::Index j = 0; j < matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(matrix, j); it; ++it)
      row_sums(it.row()) += std::abs(it.value());
  }
  return row_sums.size() > 0 ? row_sums.maxCoeff() : 0.0;
}

// x^* A x for a real sparse A (the real part: A symmetric gives a real form), accumulated in
// long double so that a small form of a large matrix (the damping of a slow mode) keeps its
// digits.
double HermitianForm(const SparseMatrix& matrix, const Eigen::VectorXcd& x) {
  long double sum = 0.0L;
  for (Eigen::Index j = 0; j < matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(matrix, j); it; ++it) {
      const std::complex<double> a = x(it.row()), b = x(it.col());
      sum += static_cast<long double>(it.value()) * (static_cast<long double>(a.real()) * b.real() +
                                                     static_cast<long double>(a.imag()) * b.imag());
    }
  }
  return static_cast<double>(sum);
}

bool Symmetric(const SparseMatrix& matrix) {
  const SparseMatrix transpose = matrix.transpose();
  return (SparseMatrix(matrix - transpose)).norm() == 0.0;
}

// B = C^T diag(alpha): input j acts along output j's row (collocated). With M, D, K symmetric
// the zeros are then the eigenvalues of M q'' + D q' + K q = 0 on ker C: x^* B u = 0 there.
bool Collocated(const LinearSystem& system) {
  const Eigen::Index m = system.num_inputs();
  if (system.output_matrix.rows() != m) return false;
  const Eigen::MatrixXd input = Eigen::MatrixXd(system.input_matrix);
  const Eigen::MatrixXd output = Eigen::MatrixXd(system.output_matrix.transpose());
  for (Eigen::Index j = 0; j < m; ++j) {
    Eigen::Index pivot = 0;
    output.col(j).cwiseAbs().maxCoeff(&pivot);
    if (output(pivot, j) == 0.0) return false;
    const double alpha = input(pivot, j) / output(pivot, j);
    if ((input.col(j) - alpha * output.col(j)).norm() != 0.0) return false;
  }
  return true;
}

// A symmetric matrix is positive definite when it is diagonally dominant with a positive
// diagonal and either every row is strictly dominant or it is irreducible with one strict row
// (Gershgorin; Taussky 1949). Exact comparisons of sums accumulated in long double; a test that
// can only say yes when it is true, not a decision by tolerance.
bool DominantPositiveDefinite(const SparseMatrix& matrix) {
  const Eigen::Index n = matrix.rows();
  const auto size = static_cast<std::size_t>(n);
  std::vector<long double> off(size, 0.0L), diagonal(size, 0.0L);
  std::vector<Eigen::Index> parent(size);
  for (Eigen::Index i = 0; i < n; ++i) parent[std::size_t(i)] = i;
  const auto find = [&parent](Eigen::Index i) {
    while (parent[std::size_t(i)] != i) {
      parent[std::size_t(i)] = parent[std::size_t(parent[std::size_t(i)])];
      i = parent[std::size_t(i)];
    }
    return i;
  };
  Eigen::Index components = n;
  for (Eigen::Index j = 0; j < matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(matrix, j); it; ++it) {
      if (it.row() == it.col()) {
        diagonal[std::size_t(j)] += it.value();
      } else if (it.value() != 0.0) {
        off[std::size_t(it.row())] += std::abs(static_cast<long double>(it.value()));
        const Eigen::Index a = find(it.row()), b = find(it.col());
        if (a != b) {
          parent[std::size_t(a)] = b;
          --components;
        }
      }
    }
  }
  bool all_strict = true, some_strict = false;
  for (std::size_t i = 0; i < std::size_t(n); ++i) {
    if (!(diagonal[i] > 0.0L) || off[i] > diagonal[i]) return false;
    const bool strict = off[i] < diagonal[i];
    all_strict = all_strict && strict;
    some_strict = some_strict || strict;
  }
  return all_strict || (components == 1 && some_strict);
}

// The structure that decides the side of every zero without their digits: M, D, K symmetric
// positive definite (DominantPositiveDefinite) and the output collocated with the input. Then
// a zero lambda with eigenvector x in ker C satisfies m lambda^2 + d lambda + k = 0 with
// m = x^* M x, d = x^* D x, k = x^* K x all > 0, so Re lambda < 0 (the energy
// q'^T M q' / 2 + q^T K q / 2 of the constrained motion decays as -q'^T D q').
std::string LeftHalfPlaneCertificate(const LinearSystem& system, bool symmetric_collocated) {
  if (!symmetric_collocated) return "";
  if (!DominantPositiveDefinite(system.mass) || !DominantPositiveDefinite(system.damping) ||
      !DominantPositiveDefinite(system.stiffness)) {
    return "";
  }
  return "certified by structure: M, D, K symmetric positive definite (diagonally dominant) and "
         "the output collocated with the input (B = C^T diag), so every zero solves "
         "m s^2 + d s + k = 0 with m, d, k > 0 and lies in the open left half plane";
}

// The q part of a zero's eigenvector (the first n entries of OP's eigenvector (q, v)),
// projected onto ker C, where the exact one lies.
Eigen::VectorXcd ZeroVector(const LinearSystem& system, const Eigen::VectorXcd& eigenvector) {
  Eigen::VectorXcd q = eigenvector.head(system.dof());
  const Eigen::MatrixXd output = Eigen::MatrixXd(system.output_matrix);
  const Eigen::MatrixXd gram = output * output.transpose();
  const Eigen::VectorXcd coefficients =
      gram.ldlt().solve(Eigen::MatrixXcd(output.cast<std::complex<double>>() * q));
  q -= output.transpose().cast<std::complex<double>>() * coefficients;
  return q;
}

// A symmetric collocated system's zero is refined by its Rayleigh quotient only when that moves
// it by at most this, relative to max(1, |lambda|): far above the eigensolver's round-off
// (1e-12 relative), far below any error a wrong vector makes (ZerosWithBounds).
constexpr double kRayleighRefinementWindow = 1e-8;

// The root of m s^2 + d s + k = 0 nearest `estimate`: the quadratic Rayleigh quotient of a
// symmetric collocated system, exact for an exact eigenvector and second-order accurate
// otherwise; with d > 0 its real part -d / (2m) (complex roots) keeps its sign however small.
std::complex<double> RayleighZero(double m, double d, double k, std::complex<double> estimate) {
  const std::complex<double> root = std::sqrt(std::complex<double>(d * d - 4.0 * m * k, 0.0));
  const std::complex<double> plus = (-d + root) / (2.0 * m), minus = (-d - root) / (2.0 * m);
  return std::abs(plus - estimate) <= std::abs(minus - estimate) ? plus : minus;
}

// R(s) = [[-(K + s D + s^2 M), B], [C, 0]], (n + m) x (n + m), for a real shift or a complex
// point s. The sum keeps the union pattern with explicit zeros, so the pattern does not depend
// on s (BuildRosenbrockMatrix's promise).
template <typename Scalar>
Eigen::SparseMatrix<Scalar> RosenbrockMatrixAt(const LinearSystem& system, Scalar s) {
  const Eigen::Index n = system.dof();
  const Eigen::Index m = system.num_inputs();
  const Eigen::SparseMatrix<Scalar> dynamic = system.stiffness.cast<Scalar>() +
                                              s * system.damping.cast<Scalar>() +
                                              (s * s) * system.mass.cast<Scalar>();
  std::vector<Eigen::Triplet<Scalar>> entries;
  entries.reserve(std::size_t(dynamic.nonZeros() + system.input_matrix.nonZeros() +
                              system.output_matrix.nonZeros()));
  for (Eigen::Index j = 0; j < dynamic.outerSize(); ++j) {
    for (typename Eigen::SparseMatrix<Scalar>::InnerIterator it(dynamic, j); it; ++it) {
      entries.emplace_back(int(it.row()), int(it.col()), -it.value());
    }
  }
  for (Eigen::Index j = 0; j < system.input_matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(system.input_matrix, j); it; ++it) {
      entries.emplace_back(int(it.row()), int(n + it.col()), Scalar(it.value()));
    }
  }
  for (Eigen::Index j = 0; j < system.output_matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(system.output_matrix, j); it; ++it) {
      entries.emplace_back(int(n + it.row()), int(it.col()), Scalar(it.value()));
    }
  }
  Eigen::SparseMatrix<Scalar> rosenbrock(n + m, n + m);
  rosenbrock.setFromTriplets(entries.begin(), entries.end());
  rosenbrock.makeCompressed();
  return rosenbrock;
}

// The fixed start of ZeroNullVectorAt's inverse-iteration step: the same every run.
Eigen::VectorXcd NullVectorStart(Eigen::Index size) {
  std::mt19937 generator(kStartSeed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXcd start(size);
  for (Eigen::Index i = 0; i < size; ++i) start(i) = uniform(generator);
  return start;
}

// Which null vector of R(lambda) = [[-Q(lambda), B], [C, 0]] ZeroNullVectorAt computes: the right
// one (R y = 0, its q part a zero's eigenvector) or the left one (y^T R = 0).
enum class NullSide { kRight, kLeft };

// ZeroNullVectorAt by a sparse LU of the bordered R(lambda) itself: for a Q(lambda) that cannot
// be factorised alone (a free rigid-body coordinate). It fills in where C or B is dense, which
// the Schur route below avoids.
Eigen::VectorXcd ZeroNullVectorBordered(const LinearSystem& system,
                                        std::complex<double> lambda,
                                        NullSide side) {
  using ComplexSparse = Eigen::SparseMatrix<std::complex<double>>;
  const ComplexSparse rosenbrock = RosenbrockMatrixAt(system, lambda);
  if (FindZeroColumn(rosenbrock)) return {};  // singular, and SparseLU might not return
  Eigen::SparseLU<ComplexSparse, Eigen::COLAMDOrdering<int>> lu(rosenbrock);
  if (lu.info() != Eigen::Success) return {};
  const Eigen::VectorXcd start = NullVectorStart(rosenbrock.rows());
  const Eigen::VectorXcd y = side == NullSide::kLeft ? Eigen::VectorXcd(lu.transpose().solve(start))
                                                     : Eigen::VectorXcd(lu.solve(start));
  if (!y.allFinite()) return {};
  return y.head(system.dof());
}

// The q part of the right or left null vector of R(lambda): one step of inverse iteration with
// R(lambda) or R(lambda)^T from a fixed vector, in complex arithmetic (lambda is within its
// error of a zero, so one step gives the null vector to that accuracy). As the real route does,
// the border goes through the Schur complement. For the left vector y = (p, w) and the start
// (r1, r2), R^T y = (r1, r2) is -Q^T p + C^T w = r1, B^T p = r2, so
//     p = Q^-T (C^T w - r1),   (B^T Q^-T C^T) w = r2 + B^T Q^-T r1,
// and the right vector is the same with Q, B and C for Q^T, C^T and B^T: one sparse LU of
// Q(lambda) (no fill from a dense C or B) and O(n m) more. Empty when the factorisation fails
// (lambda exactly a zero).
Eigen::VectorXcd ZeroNullVectorAt(const LinearSystem& system,
                                  std::complex<double> lambda,
                                  NullSide side) {
  using ComplexSparse = Eigen::SparseMatrix<std::complex<double>>;
  const Eigen::Index n = system.dof();
  const Eigen::Index m = system.num_inputs();
  ComplexSparse dynamic = system.stiffness.cast<std::complex<double>>() +
                          lambda * system.damping.cast<std::complex<double>>() +
                          (lambda * lambda) * system.mass.cast<std::complex<double>>();
  dynamic.makeCompressed();
  // A zero column: Q(lambda) is singular, and SparseLU might not return (FindZeroColumn).
  if (FindZeroColumn(dynamic)) return ZeroNullVectorBordered(system, lambda, side);
  Eigen::SparseLU<ComplexSparse, Eigen::COLAMDOrdering<int>> lu(dynamic);
  if (lu.info() != Eigen::Success) return ZeroNullVectorBordered(system, lambda, side);
  const auto solve = [&](const Eigen::MatrixXcd& right_hand_side) -> Eigen::MatrixXcd {
    if (side == NullSide::kLeft) return lu.transpose().solve(right_hand_side);
    return lu.solve(right_hand_side);
  };
  const Eigen::VectorXcd start = NullVectorStart(n + m);
  const Eigen::MatrixXcd input = Eigen::MatrixXcd(system.input_matrix.cast<std::complex<double>>());
  const Eigen::MatrixXcd output =
      Eigen::MatrixXcd(system.output_matrix.cast<std::complex<double>>());
  // Left: the border enters through C^T and leaves through B^T; right: enters through B and
  // leaves through C.
  const Eigen::MatrixXcd border_in =
      side == NullSide::kLeft ? Eigen::MatrixXcd(output.transpose()) : input;  // n x m
  const Eigen::MatrixXcd border_out =
      side == NullSide::kLeft ? Eigen::MatrixXcd(input.transpose()) : output;  // m x n
  const Eigen::MatrixXcd solved_border = solve(border_in);
  const Eigen::VectorXcd solved_start = solve(Eigen::MatrixXcd(start.head(n)));
  if (!solved_border.allFinite() || !solved_start.allFinite()) return {};
  const Eigen::MatrixXcd schur = border_out * solved_border;  // m x m
  const Eigen::VectorXcd w =
      schur.fullPivLu().solve(Eigen::VectorXcd(start.tail(m) + border_out * solved_start));
  if (!w.allFinite()) return {};
  return solved_border * w - solved_start;
}

// ZeroNullVectorAt lambda, or, when R(lambda) is exactly singular in floating point (a zero
// computed to the last bit), a relative kNullVectorOffset away, where one inverse-iteration step
// still gives the null vector to about that accuracy.
Eigen::VectorXcd ZeroNullVector(const LinearSystem& system,
                                std::complex<double> lambda,
                                NullSide side) {
  constexpr double kNullVectorOffset = 1e-8;
  Eigen::VectorXcd vector = ZeroNullVectorAt(system, lambda, side);
  if (vector.size() == 0) {
    vector = ZeroNullVectorAt(system, lambda + kNullVectorOffset * std::max(1.0, std::abs(lambda)),
                              side);
  }
  return vector;
}

// The error bound of one computed zero lambda with eigenvector q (part of OP's z = (q, v)):
// kErrorBoundSafety times the sum of
//  - ARPACK's own error, the residual |OP z - nu z| / |z| mapped to lambda = sigma + 1/nu by
//    |delta lambda| = |delta nu| / |nu|^2 (0 for the dense route, whose Schur residual is
//    round-off and counted below);
//  - the eigensolver's round-off on OP, eps max|nu| / |nu|^2;
//  - the round-off of the factorisation as a backward error eps (|K| + |lambda| |D| +
//    |lambda|^2 |M|) on the quadratic, times the zero's condition |q|^2 / |q^* (2 lambda M + D) q|
//    (Tisseur 2000, with q for the left vector as well: exact for a symmetric collocated system,
//    an estimate otherwise).
double ZeroErrorBound(const LinearSystem& system,
                      const std::array<double, 3>& norms,  // |M|, |D|, |K| (infinity norms)
                      std::complex<double> lambda,
                      std::complex<double> nu,
                      double largest_nu,
                      double arpack_residual,
                      const Eigen::VectorXcd& q,
                      const Eigen::VectorXcd& left) {
  constexpr double eps = std::numeric_limits<double>::epsilon();
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const double nu2 = std::norm(nu);
  const double magnitude = std::abs(lambda);
  const double backward =
      eps * (norms[2] + magnitude * norms[1] + magnitude * magnitude * norms[0]);
  // The zero's condition, two-sided (Tisseur 2000): |p| |q| / |p^T Q'(lambda) q|, and its
  // one-sided counterpart |q|^2 / |q^* Q'(lambda) q|; their ratio is the non-normality that the
  // operator's residual (measured with q alone) does not see.
  const Eigen::VectorXcd mass_q = system.mass.cast<std::complex<double>>() * q;
  const Eigen::VectorXcd damping_q = system.damping.cast<std::complex<double>>() * q;
  const Eigen::VectorXcd derivative_q = 2.0 * lambda * mass_q + damping_q;
  const double one_sided_derivative = std::abs(q.dot(derivative_q));
  const double one_sided =
      one_sided_derivative > 0.0 ? q.squaredNorm() / one_sided_derivative : kInfinity;
  double condition = kInfinity;
  if (left.size() > 0) {
    const double derivative = std::abs(left.dot(derivative_q.conjugate()));  // left^T Q' q
    condition = derivative > 0.0 ? left.norm() * q.norm() / derivative : kInfinity;
  }
  const double non_normality = one_sided > 0.0 ? std::max(1.0, condition / one_sided) : kInfinity;
  return kErrorBoundSafety *
         (non_normality * (arpack_residual + eps * largest_nu) / nu2 + backward * condition);
}

// A multiple zero (a Jordan block of size k, e.g. the (j - 1)-fold zero -k/d of a damped chain
// observed at mass j) has an infinite first-order condition: perturbations of size eps move it
// by about eps^(1/k) |lambda| (Hoelder). Members of a cluster of k computed zeros (relative
// distance at most kClusterDistance) get at most kErrorBoundSafety eps^(1/k) |lambda|.
void ClusterBounds(const std::vector<std::complex<double>>& zeros, std::vector<double>& bounds) {
  constexpr double kClusterDistance = 1e-6;
  constexpr double eps = std::numeric_limits<double>::epsilon();
  for (std::size_t i = 0; i < zeros.size(); ++i) {
    const double magnitude = std::abs(zeros[i]);
    int size = 0;
    for (const auto& other : zeros) {
      if (std::abs(other - zeros[i]) <= kClusterDistance * std::max(magnitude, 1e-300)) ++size;
    }
    if (size < 2) continue;
    bounds[i] =
        std::min(bounds[i], kErrorBoundSafety * std::pow(eps, 1.0 / double(size)) * magnitude);
  }
}

// Power iterations for the up-front conditioning estimate (ConditioningEstimate): a few give
// |nu|max from below within a small factor, which errs towards answering rather than refusing.
constexpr int kConditioningIterations = 8;

// The highest frequency squared of the mesh, max K_ii / M_ii over coordinates with M_ii > 0:
// within a small factor of the largest eigenvalue of (K, M) for finite-element and lumped meshes
// (Gershgorin on the diagonally scaled pencil).
double MeshFrequencySquared(const LinearSystem& system) {
  const Eigen::VectorXd stiffness = system.stiffness.diagonal();
  const Eigen::VectorXd mass = system.mass.diagonal();
  double largest = 0.0;
  for (Eigen::Index i = 0; i < mass.size(); ++i) {
    if (mass(i) > 0.0) largest = std::max(largest, std::abs(stiffness(i)) / mass(i));
  }
  return largest;
}

}  // namespace

std::string_view ToString(RosenbrockFactorization factorization) {
  for (const auto& [key, name] : kFactorizationNames) {
    if (key == factorization) return name;
  }
  return "none";
}

LinearSystem AssembleLinearSystem(const LinearModel& model,
                                  const Eigen::Ref<const Eigen::VectorXd>& parameters) {
  LinearMatrices matrices = AssembleLinearMatrices(model, parameters);
  if (model.num_constraints() == 0) {
    return {std::move(matrices.mass), std::move(matrices.damping), std::move(matrices.stiffness),
            model.input_matrix(), model.output_matrix()};
  }
  // A closed chain's constraints as a further border: inputs [B G^T], outputs [C; G], the
  // multipliers solved for as inputs and G q held at 0 as outputs (the same open-chain form as
  // LoopsAsServoConstraints, modeling/model.h).
  const SparseMatrix& constraints = model.constraint_matrix();
  const SparseMatrix constraints_transposed = constraints.transpose();
  SparseMatrix inputs(model.input_matrix().rows(),
                      model.input_matrix().cols() + constraints.rows());
  SparseMatrix outputs(model.output_matrix().rows() + constraints.rows(), constraints.cols());
  std::vector<Eigen::Triplet<double>> entries;
  const auto append = [&entries](const SparseMatrix& block, Eigen::Index row, Eigen::Index col) {
    for (Eigen::Index k = 0; k < block.outerSize(); ++k) {
      for (SparseMatrix::InnerIterator it(block, k); it; ++it) {
        entries.emplace_back(int(it.row() + row), int(it.col() + col), it.value());
      }
    }
  };
  append(model.input_matrix(), 0, 0);
  append(constraints_transposed, 0, model.input_matrix().cols());
  inputs.setFromTriplets(entries.begin(), entries.end());
  entries.clear();
  append(model.output_matrix(), 0, 0);
  append(constraints, model.output_matrix().rows(), 0);
  outputs.setFromTriplets(entries.begin(), entries.end());
  return {std::move(matrices.mass), std::move(matrices.damping), std::move(matrices.stiffness),
          std::move(inputs), std::move(outputs)};
}

void LinearSystem::Validate() const {
  const Eigen::Index n = mass.rows();
  const Eigen::Index m = input_matrix.cols();
  RequireOption(n >= 1, "LinearSystem", "mass", ShapeText(mass),
                "must have >= 1 row (the model needs >= 1 coordinate)");
  RequireOption(m >= 1, "LinearSystem", "input_matrix", ShapeText(input_matrix),
                "must have >= 1 column (>= 1 input needed)");
  RequireShape("mass", mass, n, n);
  RequireShape("damping", damping, n, n);
  RequireShape("stiffness", stiffness, n, n);
  RequireShape("input_matrix", input_matrix, n, m);
  RequireShape("output_matrix", output_matrix, m, n);
}

void LinearZeroDynamicsOptions::Validate() const {
  constexpr const char* kOwner = "LinearZeroDynamicsOptions";
  RequireOption(std::isfinite(shift), kOwner, "shift", shift, "must be finite");
  RequireOption(dense_threshold >= 0, kOwner, "dense_threshold", dense_threshold, "must be >= 0");
  RequireOption(infinite_tolerance > 0.0 && infinite_tolerance < 1.0, kOwner, "infinite_tolerance",
                infinite_tolerance, "must be > 0 and < 1");
  RequireOption(imaginary_axis_tolerance > 0.0 && imaginary_axis_tolerance < 1.0, kOwner,
                "imaginary_axis_tolerance", imaginary_axis_tolerance, "must be > 0 and < 1");
  arpack.Validate();
}

SparseMatrix BuildRosenbrockMatrix(const LinearSystem& system, double shift) {
  return RosenbrockMatrixAt(system, shift);
}

void LinearZeroDynamicsWorkspace::Factorize(const LinearSystem& system, double shift) {
  system.Validate();
  shift_ = shift;
  dof_ = system.dof();
  inputs_ = system.num_inputs();
  // The sum keeps the union pattern with explicit zeros, so the pattern is independent of shift.
  SparseMatrix dynamic = system.stiffness + shift * system.damping + (shift * shift) * system.mass;
  dynamic.makeCompressed();
  factorization_ = RosenbrockFactorization::kNone;
  if (!FactorizeSchur(system, std::move(dynamic), shift)) FactorizeBordered(system, shift);
  mass_ = system.mass;
  damping_plus_shift_mass_ = system.damping + shift * system.mass;
  rhs_.setZero(dof_ + inputs_);
  solution_.resize(dof_ + inputs_);
  inputs_solution_.resize(inputs_);
}

bool LinearZeroDynamicsWorkspace::FactorizeSchur(const LinearSystem& system,
                                                 SparseMatrix dynamic,
                                                 double shift) {
  // A row of zeros (a coordinate with no stiffness at sigma = 0: the beam's free hub) makes Q
  // singular: go to the bordered LU without factorising Q, nor keeping a copy of it.
  const Eigen::VectorXd dynamic_row_sizes = AbsoluteRowSums(dynamic);
  if (!(dynamic_row_sizes.minCoeff() > 0.0)) return false;
  if (!SamePattern(dynamic, dynamic_)) ldlt_analysed_ = dynamic_lu_analysed_ = false;
  dynamic_ = std::move(dynamic);
  dynamic_symmetric_ = IsSymmetric(dynamic_);
  const Eigen::MatrixXd input = Eigen::MatrixXd(system.input_matrix);
  if (dynamic_symmetric_) {
    if (!ldlt_analysed_) {
      dynamic_ldlt_.analyzePattern(dynamic_);
      ldlt_analysed_ = true;
      ++pattern_analyses_;
    }
    dynamic_ldlt_.factorize(dynamic_);
    if (dynamic_ldlt_.info() != Eigen::Success) return false;  // a zero pivot: Q singular
    input_solution_ = dynamic_ldlt_.solve(input);
  } else {
    if (!dynamic_lu_analysed_) {
      dynamic_lu_.analyzePattern(dynamic_);
      dynamic_lu_analysed_ = true;
      ++pattern_analyses_;
    }
    dynamic_lu_.factorize(dynamic_);
    if (dynamic_lu_.info() != Eigen::Success) {
      dynamic_lu_analysed_ = false;  // a failed factorisation leaves SparseLU unusable
      return false;
    }
    input_solution_ = dynamic_lu_.solve(input);
  }
  if (!input_solution_.allFinite()) return false;
  output_ = system.output_matrix;
  const Eigen::MatrixXd schur = output_ * input_solution_;  // S = C Q^-1 B, m x m
  if (!schur.allFinite()) return false;
  schur_.compute(schur);
  if (!schur_.isInvertible()) {
    // det R = +-det Q det S with Q regular: R(shift) is singular.
    throw NoSolution(SingularRosenbrockMessage(shift, "its Schur complement C Q^-1 B is singular"));
  }
  // The backward error of one solve with a fixed pseudo-random right-hand side [r; s].
  const Eigen::Index n = dof_, m = inputs_;
  std::mt19937 generator(kStartSeed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXd right(n + m);
  for (Eigen::Index i = 0; i < n + m; ++i) right(i) = uniform(generator);
  Eigen::VectorXd q(n), u(m);
  SolveSchur(right.head(n), right.data() + n, q, u);
  Eigen::VectorXd residual(n + m);
  residual.head(n).noalias() = system.input_matrix * u;
  residual.head(n).noalias() -= dynamic_ * q;
  residual.head(n) -= right.head(n);
  residual.tail(m).noalias() = output_ * q;
  residual.tail(m) -= right.tail(m);
  const Eigen::VectorXd row_sizes = dynamic_row_sizes + AbsoluteRowSums(system.input_matrix);
  const double matrix_size = std::max(row_sizes.maxCoeff(), AbsoluteRowSums(output_).maxCoeff());
  const double solution_size = std::max(q.lpNorm<Eigen::Infinity>(), u.lpNorm<Eigen::Infinity>());
  const double backward_error = residual.lpNorm<Eigen::Infinity>() /
                                (matrix_size * solution_size + right.lpNorm<Eigen::Infinity>());
  if (!(backward_error <= kSchurBackwardErrorLimit)) return false;
  factorization_ = dynamic_symmetric_ ? RosenbrockFactorization::kSymmetricSchur
                                      : RosenbrockFactorization::kSchur;
  return true;
}

void LinearZeroDynamicsWorkspace::FactorizeBordered(const LinearSystem& system, double shift) {
  SparseMatrix rosenbrock = BuildRosenbrockMatrix(system, shift);
  // Before the LU, which never returns for a large R with too few entries (FindZeroColumn).
  if (const std::optional<Eigen::Index> column = FindZeroColumn(rosenbrock)) {
    throw NoSolution(
        SingularRosenbrockMessage(shift, "its column " + std::to_string(*column + 1) + " is zero"));
  }
  if (!analysed_ || !SamePattern(rosenbrock, rosenbrock_)) {
    lu_.analyzePattern(rosenbrock);
    analysed_ = true;
    ++pattern_analyses_;
  }
  rosenbrock_ = std::move(rosenbrock);
  lu_.factorize(rosenbrock_);
  if (lu_.info() != Eigen::Success) {
    analysed_ = false;  // a failed factorisation leaves the solver unusable until re-analysed
    throw NoSolution(SingularRosenbrockMessage(shift, lu_.lastErrorMessage()));
  }
  factorization_ = RosenbrockFactorization::kBorderedLU;
}

void LinearZeroDynamicsWorkspace::SolveSchur(const Eigen::Ref<const Eigen::VectorXd>& top,
                                             const double* bottom,
                                             Eigen::Ref<Eigen::VectorXd> q,
                                             Eigen::Ref<Eigen::VectorXd> u) const {
  // -Q q + B u = top, C q = bottom: q = W u - z with z = Q^-1 top, and S u = bottom + C z.
  if (dynamic_symmetric_) {
    q = dynamic_ldlt_.solve(top);
  } else {
    q = dynamic_lu_.solve(top);
  }
  Eigen::VectorXd image = output_ * q;
  if (bottom != nullptr) image += Eigen::Map<const Eigen::VectorXd>(bottom, inputs_);
  u = schur_.solve(image);
  q = input_solution_ * u - q;
}

void LinearZeroDynamicsWorkspace::ApplyShiftInvert(const double* x, double* y) const {
  assert(factorization_ != RosenbrockFactorization::kNone);
  const Eigen::Map<const Eigen::VectorXd> w1(x, dof_), w2(x + dof_, dof_);
  Eigen::Map<Eigen::VectorXd> q(y, dof_), v(y + dof_, dof_);
  rhs_.head(dof_).noalias() = mass_ * w2;
  rhs_.head(dof_).noalias() += damping_plus_shift_mass_ * w1;
  if (factorization_ == RosenbrockFactorization::kBorderedLU) {
    rhs_.tail(inputs_).setZero();
    solution_ = lu_.solve(rhs_);
    q = solution_.head(dof_);
  } else {
    SolveSchur(rhs_.head(dof_), nullptr, q, inputs_solution_);
  }
  v = w1 + shift_ * q;
}

std::vector<std::complex<double>> NearestEigenvalues(std::vector<std::complex<double>> eigenvalues,
                                                     double shift,
                                                     std::size_t count) {
  std::sort(eigenvalues.begin(), eigenvalues.end(),
            [shift](const std::complex<double>& a, const std::complex<double>& b) {
              return std::abs(a - shift) < std::abs(b - shift);
            });
  if (eigenvalues.size() > count) eigenvalues.resize(count);
  SortEigenvalues(eigenvalues);
  return eigenvalues;
}

double ZeroConditioningEstimate(const LinearSystem& system,
                                const LinearZeroDynamicsWorkspace& workspace,
                                const Eigen::VectorXd& start,
                                double shift) {
  // The geometric mean of the growth factors |OP v_j| (v_j normalised), i.e. |OP^k s|^(1/k):
  // robust where the ratio of two successive iterates is not (a dominant conjugate pair makes
  // it oscillate, and OP's q and v parts differ in scale by 1/|lambda|).
  Eigen::VectorXd vector = start, image(start.size());
  double log_growth = 0.0;
  for (int i = 0; i < kConditioningIterations; ++i) {
    workspace.ApplyShiftInvert(vector.data(), image.data());
    const double growth = image.norm();
    if (!(growth > 0.0) || !std::isfinite(growth)) return 0.0;
    log_growth += std::log(growth);
    vector = image / growth;
  }
  const double largest_nu = std::exp(log_growth / kConditioningIterations);
  const double slowest = std::abs(shift) + 1.0 / largest_nu;  // >= |lambda| of the nearest zero
  return std::numeric_limits<double>::epsilon() * MeshFrequencySquared(system) /
         (slowest * slowest);
}

void RefuseIllConditioned(const LinearSystem& system,
                          const LinearZeroDynamicsWorkspace& workspace,
                          const Eigen::VectorXd& start,
                          const LinearZeroDynamicsOptions& options) {
  const double estimate = ZeroConditioningEstimate(system, workspace, start, options.shift);
  if (estimate < kNoDigitConditioning) return;
  throw NoSolution("the zeros nearest the shift " + FormatSignificant(options.shift, 6) +
                   " would carry no correct digit: eps * max K_ii/M_ii / |lambda|^2 = " +
                   FormatSignificant(estimate, 2) +
                   " >= " + FormatSignificant(kNoDigitConditioning, 2) +
                   " (the mesh's highest frequency squared against the slowest zero's |lambda|^2, "
                   "times the machine precision): use fewer elements (it falls like N^-4 for "
                   "beam elements, N^-2 for a chain: 10 times fewer beam elements divide it by "
                   "1e4), or a shift nearer the zeros of interest");
}

namespace {

// The eigenpairs of OP behind the zeros: the computed nu, the indices of those kept as finite
// zeros, their eigenvectors z = (q, v) of OP (one per kept nu), ARPACK's residuals
// |OP z - nu z| / |z|, and the scale of |nu| for the error bounds.
struct OperatorEigenpairs {
  std::vector<std::complex<double>> nus;
  std::vector<std::size_t> kept;
  std::vector<Eigen::VectorXcd> vectors;
  std::vector<double> residuals;
  double largest_nu = 0.0;
};

// k is capped at the number of finite zeros.
Eigen::Index WantedZeros(const LinearZeroDynamicsOptions& options, Eigen::Index zero_count) {
  Eigen::Index wanted = options.arpack.eigenvalues;
  if (zero_count >= 0) wanted = std::min(wanted, zero_count);
  return wanted;
}

// ARPACK needs k <= 2n - 2, else dense.
bool UseDenseSolver(const LinearZeroDynamicsOptions& options, Eigen::Index n, Eigen::Index wanted) {
  const Eigen::Index operator_size = 2 * n;
  return options.solver == LinearEigenSolver::kDense ||
         (options.solver == LinearEigenSolver::kAuto && n <= options.dense_threshold) ||
         wanted > operator_size - 2;
}

// Every eigenvalue of OP, densely, and the eigenvectors of the finite zeros among them.
OperatorEigenpairs DenseEigenpairs(const LinearSystem& system,
                                   const LinearZeroDynamicsWorkspace& workspace,
                                   Eigen::Index zero_count,
                                   const LinearZeroDynamicsOptions& options) {
  OperatorEigenpairs pairs;
  const Eigen::VectorXcd values = DenseOperatorEigenvalues(system, workspace);
  pairs.nus.assign(values.data(), values.data() + values.size());
  pairs.kept = FiniteZeroIndices(pairs.nus, zero_count, 0.0, options);
  for (const std::size_t i : pairs.kept) {
    // The zero's eigenvector q (the head of OP's (q, lambda q)); empty (no bound) where
    // R(lambda) cannot be factorised at all.
    pairs.vectors.push_back(
        ZeroNullVector(system, options.shift + 1.0 / pairs.nus[i], NullSide::kRight));
    pairs.residuals.push_back(0.0);  // the Schur residual is round-off: in the bound's eps term
  }
  return pairs;
}

// ARPACK's shift-invert run for `wanted` eigenvalues of OP, with Ritz vectors.
ArpackResult RunShiftInvertArpack(const LinearZeroDynamicsWorkspace& workspace,
                                  Eigen::Index operator_size,
                                  Eigen::Index wanted,
                                  const Eigen::VectorXd& start,
                                  const LinearZeroDynamicsOptions& options) {
  ArpackOptions arpack = options.arpack;
  arpack.eigenvalues = static_cast<int>(wanted);
  arpack.ritz_vectors = true;
  const auto apply = [&workspace](const double* x, double* y) { workspace.ApplyShiftInvert(x, y); };
  const ArpackTarget target = options.target == EigenvalueTarget::kNearest
                                  ? ArpackTarget::kLargestMagnitude
                                  : ArpackTarget::kLargestRealPart;
  try {
    return ArpackEigenvalues(operator_size, apply, target, arpack, start);
  } catch (const NoSolution& error) {
    if (options.target != EigenvalueTarget::kRightmost) throw;
    // Limit (2) of EigenvalueTarget::kRightmost: say what to do about it.
    throw NoSolution(std::string(error.what()) +
                     "; the rightmost route converges slowly when every zero is left of "
                     "the shift (lightly damped modes crowd near Re 1/(lambda - shift) = 0): "
                     "use the nearest route, or a shift right of the zeros of interest");
  }
}

// The Ritz vectors of the kept nu and their residuals |OP z - nu z| / |z|.
void AddRitzPairs(const ArpackResult& arpack,
                  const LinearZeroDynamicsWorkspace& workspace,
                  Eigen::Index operator_size,
                  OperatorEigenpairs& pairs) {
  Eigen::VectorXd real_image(operator_size), imaginary_image(operator_size);
  for (const std::size_t i : pairs.kept) {
    Eigen::VectorXcd z = RitzVector(arpack, i);
    const Eigen::VectorXd real_part = z.real(), imaginary_part = z.imag();
    workspace.ApplyShiftInvert(real_part.data(), real_image.data());
    workspace.ApplyShiftInvert(imaginary_part.data(), imaginary_image.data());
    Eigen::VectorXcd image(operator_size);
    image.real() = real_image;
    image.imag() = imaginary_image;
    const double size = z.norm();
    pairs.residuals.push_back(size > 0.0 ? (image - pairs.nus[i] * z).norm() / size
                                         : std::numeric_limits<double>::infinity());
    pairs.vectors.push_back(std::move(z));
  }
}

// The eigenpairs of OP nearest the target, by ARPACK; the run is kept in `result` (without its
// Ritz vectors, which `pairs` holds).
OperatorEigenpairs ArpackEigenpairs(const LinearSystem& system,
                                    const LinearZeroDynamicsWorkspace& workspace,
                                    Eigen::Index wanted,
                                    const LinearZeroDynamicsOptions& options,
                                    LinearZeroDynamics& result) {
  OperatorEigenpairs pairs;
  const Eigen::Index operator_size = 2 * system.dof();
  const Eigen::VectorXd start = StartVector(workspace, operator_size);
  RefuseIllConditioned(system, workspace, start, options);
  result.arpack = RunShiftInvertArpack(workspace, operator_size, wanted, start, options);
  // The scale of |nu| for the infinite-eigenvalue test: 'LM' returns the largest |nu| itself;
  // 'LR' need not, so estimate it by power iteration.
  const double scale = options.target == EigenvalueTarget::kNearest
                           ? 0.0
                           : EstimateLargestMagnitude(workspace, start);
  pairs.largest_nu = scale;
  pairs.nus = result.arpack.ritz_values;
  pairs.kept = FiniteZeroIndices(pairs.nus, kUnknownZeroCount, scale, options);
  if (pairs.kept.size() > std::size_t(wanted)) {
    pairs.kept.resize(std::size_t(wanted));  // dneupd: nev + 1
  }
  AddRitzPairs(result.arpack, workspace, operator_size, pairs);
  result.arpack.ritz_vectors.clear();
  result.arpack.ritz_vectors.shrink_to_fit();
  return pairs;
}

// The zeros lambda = shift + 1/nu of the kept eigenpairs, in `result`, and the error bound of
// each. A symmetric collocated system refines each zero by its Rayleigh quotient.
std::vector<double> ZerosWithBounds(const LinearSystem& system,
                                    const OperatorEigenpairs& pairs,
                                    bool symmetric_collocated,
                                    double shift,
                                    LinearZeroDynamics& result) {
  const std::array<double, 3> norms = {InfinityNorm(system.mass), InfinityNorm(system.damping),
                                       InfinityNorm(system.stiffness)};
  std::vector<double> bounds;
  for (std::size_t j = 0; j < pairs.kept.size(); ++j) {
    const std::complex<double> nu = pairs.nus[pairs.kept[j]];
    std::complex<double> lambda = shift + 1.0 / nu;
    if (pairs.vectors[j].size() == 0) {  // no vector (dense route, R(lambda) not factorisable)
      bounds.push_back(std::numeric_limits<double>::infinity());
      result.eigenvalues.push_back(lambda);
      continue;
    }
    const Eigen::VectorXcd q = symmetric_collocated
                                   ? ZeroVector(system, pairs.vectors[j])
                                   : Eigen::VectorXcd(pairs.vectors[j].head(system.dof()));
    // A symmetric collocated system: Q(lambda)^T = Q(lambda) and q^T B = (C q)^T diag = 0, so
    // the left vector is q itself.
    const Eigen::VectorXcd left =
        symmetric_collocated ? q : ZeroNullVector(system, lambda, NullSide::kLeft);
    bounds.push_back(
        ZeroErrorBound(system, norms, lambda, nu, pairs.largest_nu, pairs.residuals[j], q, left));
    if (symmetric_collocated) {
      // The quotient is as good as q. Where the zero is also (nearly) an eigenvalue of
      // Q(lambda) (a mode of the structure that leaves the outputs at rest: the ring of
      // `generate chain --closed`), one step of inverse iteration through the Schur
      // complement gives a q off the zero's vector, and the quotient moved such zeros by 1 %.
      // The refinement only corrects round-off (a lightly damped zero's real part), so a
      // refined zero further than that from the eigensolver's is not taken.
      const std::complex<double> refined =
          RayleighZero(HermitianForm(system.mass, q), HermitianForm(system.damping, q),
                       HermitianForm(system.stiffness, q), lambda);
      if (std::abs(refined - lambda) <=
          kRayleighRefinementWindow * std::max(1.0, std::abs(lambda))) {
        lambda = refined;
      }
    }
    result.eigenvalues.push_back(lambda);
  }
  return bounds;
}

// The finite zeros (zero_count != 0), by the dense or the ARPACK route, with their bounds,
// stability and modes.
void ComputeFiniteZeros(const LinearSystem& system,
                        LinearZeroDynamicsWorkspace& workspace,
                        Eigen::Index zero_count,
                        Eigen::Index wanted,
                        const LinearZeroDynamicsOptions& options,
                        LinearZeroDynamics& result) {
  workspace.Factorize(system, options.shift);
  OperatorEigenpairs pairs;
  if (result.solver_used == LinearEigenSolver::kDense) {
    pairs = DenseEigenpairs(system, workspace, zero_count, options);
    result.complete = true;
  } else {
    pairs = ArpackEigenpairs(system, workspace, wanted, options, result);
    result.complete = zero_count >= 0 && Eigen::Index(pairs.kept.size()) == zero_count;
  }
  for (const auto& nu : pairs.nus) pairs.largest_nu = std::max(pairs.largest_nu, std::abs(nu));
  const bool symmetric_collocated = Symmetric(system.mass) && Symmetric(system.damping) &&
                                    Symmetric(system.stiffness) && Collocated(system);
  std::vector<double> bounds =
      ZerosWithBounds(system, pairs, symmetric_collocated, options.shift, result);
  ClusterBounds(result.eigenvalues, bounds);
  FinishZeroDynamicsWithBounds(result, std::move(bounds), options.imaginary_axis_tolerance);
  const std::string certificate = LeftHalfPlaneCertificate(system, symmetric_collocated);
  if (!certificate.empty() && !result.eigenvalues.empty()) {
    result.stability = Stability::kAsymptoticallyStable;
    result.minimum_phase = true;
    result.stability_note = certificate;
  }
}

}  // namespace

LinearZeroDynamics ComputeLinearZeroDynamics(const LinearSystem& system,
                                             LinearZeroDynamicsWorkspace& workspace,
                                             Eigen::Index zero_count,
                                             const LinearZeroDynamicsOptions& options) {
  options.Validate();
  system.Validate();
  LinearZeroDynamics result;
  result.zero_count = zero_count;
  result.target = options.target;
  result.shift = options.shift;
  const Eigen::Index wanted = WantedZeros(options, zero_count);
  result.solver_used = UseDenseSolver(options, system.dof(), wanted) ? LinearEigenSolver::kDense
                                                                     : LinearEigenSolver::kArpack;
  if (zero_count != 0) {
    ComputeFiniteZeros(system, workspace, zero_count, wanted, options, result);
  } else {
    result.complete = true;
    FinishZeroDynamics(result, options.imaginary_axis_tolerance);
  }
  result.scope = zero_count == 0 ? "no zero dynamics (flat)"
                                 : Scope(result, Eigen::Index(result.eigenvalues.size()));
  return result;
}

}  // namespace servokit
