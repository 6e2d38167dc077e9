#include "analysis/linear_zero_dynamics.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <utility>

#include "models/errors.h"
#include "models/option_check.h"

namespace servokit {
namespace {

constexpr std::pair<LinearEigenSolver, std::string_view> kSolverNames[] = {
    {LinearEigenSolver::kAuto, "auto"},
    {LinearEigenSolver::kDense, "dense"},
    {LinearEigenSolver::kArpack, "arpack"},
};

constexpr std::pair<EigenvalueTarget, std::string_view> kTargetNames[] = {
    {EigenvalueTarget::kNearest, "nearest"},
    {EigenvalueTarget::kRightmost, "rightmost"},
};

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

std::string ShiftText(double shift) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", shift);
  return buffer;
}

std::string SingularRosenbrockMessage(double shift, const std::string& detail) {
  return "the Rosenbrock matrix [[-(K + s D + s^2 M), B], [C, 0]] is singular at the shift s = " +
         ShiftText(shift) + " (s is an invariant zero, or the model is not invertible): " + detail +
         "; choose another shift";
}

// nu of the dense OP, 2n x 2n, all eigenvalues.
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

// Keeps the nu that belong to finite zeros and maps them to lambda = shift + 1/nu: the
// zero_count largest in magnitude when known, else those above infinite_tolerance * max |nu|.
std::vector<std::complex<double>> FiniteZeros(std::vector<std::complex<double>> nus,
                                              Eigen::Index zero_count,
                                              double scale,
                                              const LinearZeroDynamicsOptions& options) {
  std::sort(nus.begin(), nus.end(),
            [](const std::complex<double>& a, const std::complex<double>& b) {
              return std::abs(a) > std::abs(b);
            });
  if (zero_count >= 0 && std::size_t(zero_count) < nus.size()) {
    nus.resize(std::size_t(zero_count));
  }
  for (const auto& nu : nus) scale = std::max(scale, std::abs(nu));
  std::vector<std::complex<double>> zeros;
  for (const auto& nu : nus) {
    if (zero_count < 0 && std::abs(nu) <= options.infinite_tolerance * scale) continue;
    if (nu == 0.0) continue;
    zeros.push_back(options.shift + 1.0 / nu);
  }
  return zeros;
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
    return "the " + Count(computed) + " zeros nearest " + ShiftText(result.shift) + of +
           " (ARPACK shift-invert); stability and modes of these only";
  }
  return "the " + Count(computed) + " zeros with largest Re 1/(lambda - " +
         ShiftText(result.shift) + ")" + of +
         " (ARPACK shift-invert): every zero with Re lambda > " + ShiftText(result.shift) +
         " ranks first";
}

}  // namespace

std::string_view ToString(LinearEigenSolver solver) {
  for (const auto& [key, name] : kSolverNames) {
    if (key == solver) return name;
  }
  return "auto";
}

std::string_view ToString(EigenvalueTarget target) {
  for (const auto& [key, name] : kTargetNames) {
    if (key == target) return name;
  }
  return "nearest";
}

std::string_view ToString(RosenbrockFactorization factorization) {
  for (const auto& [key, name] : kFactorizationNames) {
    if (key == factorization) return name;
  }
  return "none";
}

std::optional<LinearEigenSolver> LinearEigenSolverFromString(std::string_view text) {
  for (const auto& [key, name] : kSolverNames) {
    if (name == text) return key;
  }
  return std::nullopt;
}

std::optional<EigenvalueTarget> EigenvalueTargetFromString(std::string_view text) {
  for (const auto& [key, name] : kTargetNames) {
    if (name == text) return key;
  }
  return std::nullopt;
}

LinearSystem AssembleLinearSystem(const LinearModel& model,
                                  const Eigen::Ref<const Eigen::VectorXd>& parameters) {
  LinearMatrices matrices = AssembleLinearMatrices(model, parameters);
  return {std::move(matrices.mass), std::move(matrices.damping), std::move(matrices.stiffness),
          model.input_matrix(), model.output_matrix()};
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
  const Eigen::Index n = system.dof();
  const Eigen::Index m = system.num_inputs();
  // The sum keeps the union pattern with explicit zeros, so the pattern is independent of shift.
  const SparseMatrix dynamic =
      system.stiffness + shift * system.damping + (shift * shift) * system.mass;
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(std::size_t(dynamic.nonZeros() + system.input_matrix.nonZeros() +
                              system.output_matrix.nonZeros()));
  for (Eigen::Index j = 0; j < dynamic.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(dynamic, j); it; ++it) {
      entries.emplace_back(int(it.row()), int(it.col()), -it.value());
    }
  }
  for (Eigen::Index j = 0; j < system.input_matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(system.input_matrix, j); it; ++it) {
      entries.emplace_back(int(it.row()), int(n + it.col()), it.value());
    }
  }
  for (Eigen::Index j = 0; j < system.output_matrix.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(system.output_matrix, j); it; ++it) {
      entries.emplace_back(int(n + it.row()), int(it.col()), it.value());
    }
  }
  SparseMatrix rosenbrock(n + m, n + m);
  rosenbrock.setFromTriplets(entries.begin(), entries.end());
  rosenbrock.makeCompressed();
  return rosenbrock;
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
  const Eigen::Index n = system.dof();
  const Eigen::Index operator_size = 2 * n;
  // k is capped at the number of finite zeros; ARPACK needs k <= 2n - 2, else dense.
  Eigen::Index wanted = options.arpack.eigenvalues;
  if (zero_count >= 0) wanted = std::min(wanted, zero_count);
  bool dense = options.solver == LinearEigenSolver::kDense ||
               (options.solver == LinearEigenSolver::kAuto && n <= options.dense_threshold) ||
               wanted > operator_size - 2;
  result.solver_used = dense ? LinearEigenSolver::kDense : LinearEigenSolver::kArpack;

  if (zero_count != 0) {
    workspace.Factorize(system, options.shift);
    if (dense) {
      const Eigen::VectorXcd nus = DenseOperatorEigenvalues(system, workspace);
      result.eigenvalues =
          FiniteZeros({nus.data(), nus.data() + nus.size()}, zero_count, 0.0, options);
      result.complete = true;
    } else {
      ArpackOptions arpack = options.arpack;
      arpack.eigenvalues = static_cast<int>(wanted);
      const Eigen::VectorXd start = StartVector(workspace, operator_size);
      const auto apply = [&workspace](const double* x, double* y) {
        workspace.ApplyShiftInvert(x, y);
      };
      const ArpackTarget target = options.target == EigenvalueTarget::kNearest
                                      ? ArpackTarget::kLargestMagnitude
                                      : ArpackTarget::kLargestRealPart;
      try {
        result.arpack = ArpackEigenvalues(operator_size, apply, target, arpack, start);
      } catch (const NoSolution& error) {
        if (options.target != EigenvalueTarget::kRightmost) throw;
        // Limit (2) of EigenvalueTarget::kRightmost: say what to do about it.
        throw NoSolution(std::string(error.what()) +
                         "; the rightmost route converges slowly when every zero is left of "
                         "the shift (lightly damped modes crowd near Re 1/(lambda - shift) = 0): "
                         "use the nearest route, or a shift right of the zeros of interest");
      }
      // The scale of |nu| for the infinite-eigenvalue test: 'LM' returns the largest |nu| itself;
      // 'LR' need not, so estimate it by power iteration.
      const double scale = options.target == EigenvalueTarget::kNearest
                               ? 0.0
                               : EstimateLargestMagnitude(workspace, start);
      result.eigenvalues =
          FiniteZeros(result.arpack.ritz_values, kUnknownZeroCount, scale, options);
      if (result.eigenvalues.size() > std::size_t(wanted)) {
        result.eigenvalues.resize(std::size_t(wanted));  // dneupd may return nev + 1
      }
      result.complete = zero_count >= 0 && Eigen::Index(result.eigenvalues.size()) == zero_count;
    }
  } else {
    result.complete = true;
  }
  FinishZeroDynamics(result, options.imaginary_axis_tolerance);
  result.scope = zero_count == 0 ? "no zero dynamics (flat)"
                                 : Scope(result, Eigen::Index(result.eigenvalues.size()));
  return result;
}

}  // namespace servokit
