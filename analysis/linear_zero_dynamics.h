#pragma once
// Zero dynamics of large sparse linear models (issue #6): M q'' + D q' + K q = B u, y = C q,
// M, D, K sparse n x n (M invertible), B n x m, C m x n.
//
// Why the zeros are pencil eigenvalues. The zero dynamics are the motions with y = 0 (the
// output held at its operating value, paper Sect. 4). An exponential motion q = q0 e^(lambda t),
// q' = v0 e^(lambda t), u = u0 e^(lambda t) does that exactly when
//     lambda q0 = v0,   lambda M v0 = -K q0 - D v0 + B u0,   C q0 = 0,
// i.e. (A - lambda E) (q0, v0, u0) = 0 for the Rosenbrock pencil in first-order form
//         [  0   I  0 ]            [ I  0  0 ]
//     A = [ -K  -D  B ],       E = [ 0  M  0 ]      (size 2n + m, unknowns (q, v, u)).
//         [  C   0  0 ]            [ 0  0  0 ]
// So the finite generalized eigenvalues of (A, E) are the invariant zeros, which for a
// left-invertible system are the eigenvalues of the zero dynamics (the same pencil as
// InvariantZeros in analysis/zero_dynamics.h). How many: eliminating v = lambda q,
//     det(A - lambda E) = +-det R(lambda),  R(lambda) = [[-Q(lambda), B], [C, 0]],
//     Q(lambda) = M lambda^2 + D lambda + K,
// and det R(lambda) = +-det Q(lambda) det(C Q(lambda)^-1 B) (Schur complement). det Q has degree
// 2n with leading coefficient det M; the transfer matrix C Q^-1 B = diag(lambda^-r_i) (Gamma +
// O(1/lambda)) with the decoupling matrix Gamma (rows C_i A^(r_i-1) B). When Gamma is regular,
// det R is a polynomial of degree exactly 2n - sum r_i: that many finite zeros, and the other
// m + sum r_i eigenvalues of the pencil are infinite.
//
// The operator both routes use. For a real shift sigma, (A - sigma E) x = E w with w = (w1, w2)
// eliminates to the (n + m) x (n + m) Rosenbrock matrix at sigma,
//     R(sigma) [q; u] = [M w2 + (D + sigma M) w1; 0],   v = w1 + sigma q,
// so OP = (A - sigma E)^-1 E acts on (q, v) in dimension 2n (its value does not depend on u),
// through one solve with R(sigma), which is the block elimination of A - sigma E and half its
// size; R(sigma) itself is applied through its Schur complement on the border (B, C), with only
// Q(sigma) factorised sparse (LinearZeroDynamicsWorkspace). Its eigenvalues are nu = 1/(lambda -
// sigma) for the finite zeros and nu = 0 for the infinite ones.
//
// Routes: dense (all zeros: the 2n x 2n matrix of OP and Eigen's real Schur eigensolver;
// measured on the damped chain 3-5 times faster than QZ of the (2n + m) pencil by
// GeneralizedEigenSolver (n = 200: 0.19 s against 0.70 s; n = 400: 2.0 s against 4.8 s), the
// same zeros to 1e-12; ~35 s at n = 1000) and ARPACK (the k zeros nearest sigma, or the k with
// largest Re 1/(lambda - sigma), see EigenvalueTarget).
#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <Eigen/SparseLU>
#include <complex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/zero_dynamics.h"
#include "base/vocabulary.h"
#include "modeling/linear_model.h"
#include "numerics/arpack_eigen.h"

namespace servokit {

/// The matrices of a linear model, at one parameter point.
struct LinearSystem {
  SparseMatrix mass;           // M, n x n, invertible (symmetric positive definite for mechanics)
  SparseMatrix damping;        // D, n x n (may have no entries)
  SparseMatrix stiffness;      // K, n x n
  SparseMatrix input_matrix;   // B, n x m
  SparseMatrix output_matrix;  // C, m x n
  Eigen::Index dof() const { return mass.rows(); }
  Eigen::Index num_inputs() const { return input_matrix.cols(); }
  /// Throws UsageError when the shapes do not fit (M, D, K n x n, B n x m, C m x n, m >= 1).
  void Validate() const;
};

/// The matrices of `model` at `parameters` (size model.parameter_names().size(); SI), by
/// AssembleLinearMatrices, with the model's B and C.
LinearSystem AssembleLinearSystem(const LinearModel& model,
                                  const Eigen::Ref<const Eigen::VectorXd>& parameters);

struct LinearZeroDynamicsOptions {
  LinearEigenSolver solver = LinearEigenSolver::kAuto;
  EigenvalueTarget target = EigenvalueTarget::kNearest;
  // Real shift sigma of (A - sigma E)^-1 E (1/s). 0: the slowest zeros. Must not be a zero itself
  // (then R(sigma) is singular and the computation throws NoSolution naming the shift).
  double shift = 0.0;
  // auto uses the dense route up to this many coordinates: at n = 200 it takes ~0.2 s and gives
  // every zero; above, its (2n)^3 cost grows past ARPACK's (n = 1000: 35 s against 0.04 s).
  Eigen::Index dense_threshold = 200;
  // The ARPACK route: options.arpack.eigenvalues is k (capped at the number of finite zeros).
  ArpackOptions arpack;
  // A computed nu = 1/(lambda - sigma) with |nu| at most this times the largest |nu| is taken as
  // an infinite eigenvalue (nu = 0 up to round-off: an infinite eigenvalue of index r moves by
  // ~(eps |OP|)^(1/r), 1e-8 for r = 2). Used only when the number of finite zeros is not known;
  // when it is, the dense route keeps exactly that many nu of largest magnitude.
  double infinite_tolerance = 1e-6;
  // A zero whose |Re lambda| is within its own error bound counts as on the imaginary axis when
  // its damping ratio |Re lambda| / |lambda| is at most this, and as undetermined otherwise
  // (FinishZeroDynamicsWithBounds); beyond its bound its side is its sign, whatever this says.
  double imaginary_axis_tolerance = 1e-9;
  /// Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

/// How LinearZeroDynamicsWorkspace::Factorize applied R(sigma)^-1 (see the workspace).
enum class RosenbrockFactorization {
  kNone,            // Factorize not called yet
  kSymmetricSchur,  // LDLT of Q(sigma) (symmetric) + the m x m Schur complement
  kSchur,           // sparse LU of Q(sigma) (not symmetric) + the m x m Schur complement
  kBorderedLU,      // sparse LU of R(sigma) itself (Q(sigma) singular or the Schur solve
                    // not accurate: the fallback, exact but O(n m) fill for a dense C row)
};
std::string_view ToString(RosenbrockFactorization factorization);  // "symmetric-schur", ...

/// The factorisation of R(sigma) = [[-Q, B], [C, 0]], Q = K + sigma D + sigma^2 M, reused across
/// parameter points: a sweep over one model analyses the pattern once and only refactorises
/// (the pattern of Q, and of R, does not depend on the parameter values or on sigma).
///
/// The border (B, C) is applied through the Schur complement, so that only Q is factorised
/// sparse (LDLT when Q is symmetric, else LU): with W = Q^-1 B (dense n x m) and
/// S = C W (m x m, LU), R [q; u] = [r; s] is z = Q^-1 r, u = S^-1 (s + C z), q = W u - z, one
/// sparse solve with Q plus O(n m). A sparse LU of R itself fills in when a row of C is dense
/// (an output that mixes many coordinates: O(n^2) at n = 10^4 for a chain), the Schur route never
/// does. det R = +-det Q det S: with Q regular, S is singular exactly when R is. When Q(sigma) is
/// singular (a row of zeros, as the free hub of `generate beam` at sigma = 0, or a zero pivot)
/// or the Schur solve's
/// backward error on a test right-hand side exceeds kSchurBackwardErrorLimit, the workspace falls
/// back to the sparse LU of R (the route of issue #6) and says so in factorization().
class LinearZeroDynamicsWorkspace {
 public:
  /// Factorises R(shift) of `system`; analyses a pattern only when it changed since the last
  /// call. Throws NoSolution if R(shift) is singular (shift is a zero, or the system is not
  /// invertible).
  void Factorize(const LinearSystem& system, double shift);
  /// y = OP x = (A - shift E)^-1 E x on (q, v), sizes 2n; Factorize first.
  void ApplyShiftInvert(const double* x, double* y) const;
  /// How many times a pattern was analysed (a sweep expects 1: the pattern of Q, or of R when
  /// every point falls back to the bordered LU).
  int pattern_analyses() const { return pattern_analyses_; }
  /// The route of the last Factorize.
  RosenbrockFactorization factorization() const { return factorization_; }

  /// Largest normwise backward error |R x - r| / (|R| |x| + |r|) (infinity norms) of the Schur
  /// solve on a test right-hand side for which the Schur route is kept. LDLT and LU are backward
  /// stable for a regular Q; a Q close to singular (relative to R) shows here.
  static constexpr double kSchurBackwardErrorLimit = 1e-11;

 private:
  // The Schur route; false when Q is singular or the solve is not accurate (then the bordered
  // LU is used). Throws NoSolution when S is singular.
  bool FactorizeSchur(const LinearSystem& system, SparseMatrix dynamic, double shift);
  void FactorizeBordered(const LinearSystem& system, double shift);
  // [q; u] = R^-1 [top; bottom] by the Schur route; `bottom` of size m (nullptr: zero).
  void SolveSchur(const Eigen::Ref<const Eigen::VectorXd>& top,
                  const double* bottom,
                  Eigen::Ref<Eigen::VectorXd> q,
                  Eigen::Ref<Eigen::VectorXd> u) const;

  // Q(sigma) and its factorisations (the pattern of the last Q is kept to detect a change).
  SparseMatrix dynamic_;
  bool dynamic_symmetric_ = false;
  Eigen::SimplicialLDLT<SparseMatrix> dynamic_ldlt_;
  Eigen::SparseLU<SparseMatrix, Eigen::COLAMDOrdering<int>> dynamic_lu_;
  bool ldlt_analysed_ = false, dynamic_lu_analysed_ = false;
  SparseMatrix output_;                      // C
  Eigen::MatrixXd input_solution_;           // W = Q^-1 B, n x m
  Eigen::FullPivLU<Eigen::MatrixXd> schur_;  // of S = C W
  // The fallback: the sparse LU of R.
  Eigen::SparseLU<SparseMatrix, Eigen::COLAMDOrdering<int>> lu_;
  SparseMatrix rosenbrock_;
  bool analysed_ = false;

  RosenbrockFactorization factorization_ = RosenbrockFactorization::kNone;
  SparseMatrix damping_plus_shift_mass_;  // D + sigma M
  SparseMatrix mass_;
  double shift_ = 0.0;
  Eigen::Index dof_ = 0, inputs_ = 0;
  int pattern_analyses_ = 0;
  mutable Eigen::VectorXd rhs_, solution_, inputs_solution_;
};

/// R(sigma) = [[-(K + sigma D + sigma^2 M), B], [C, 0]], (n + m) x (n + m), with the pattern
/// union of K, D, M (explicit zeros kept), the same for every sigma.
SparseMatrix BuildRosenbrockMatrix(const LinearSystem& system, double shift);

// The eigenvalues are the zeros computed, and stability and modes are theirs
// (FinishZeroDynamics): when not `complete`, of the computed zeros only; see `scope`.
struct LinearZeroDynamics : ZeroDynamicsSpectrum {
  bool complete = false;         // every finite zero was computed
  Eigen::Index zero_count = -1;  // number of finite zeros (2n - sum r) if known, else -1
  LinearEigenSolver solver_used = LinearEigenSolver::kDense;
  EigenvalueTarget target = EigenvalueTarget::kNearest;
  double shift = 0.0;
  ArpackResult arpack;  // the ARPACK run (empty for the dense route)
  std::string scope;    // one line: what the eigenvalues are ("all 6 zeros", ...)
};

/// Number of finite zeros not known (decoupling matrix singular or not computed).
inline constexpr Eigen::Index kUnknownZeroCount = -1;

/// The zero dynamics of `system` (see the file comment). `zero_count` is the number of finite
/// zeros, 2n - sum of the relative degrees when the decoupling matrix is regular (ComputeLinear-
/// Analysis passes it), or kUnknownZeroCount. `workspace` is overwritten. Throws UsageError for
/// bad options or shapes, NoSolution if R(shift) is singular or an eigensolver fails.
LinearZeroDynamics ComputeLinearZeroDynamics(const LinearSystem& system,
                                             LinearZeroDynamicsWorkspace& workspace,
                                             Eigen::Index zero_count,
                                             const LinearZeroDynamicsOptions& options = {});

/// At or above this ZeroConditioningEstimate the ARPACK route refuses (NoSolution): the
/// first-order error of the slowest zeros would be about their size, so no digit is right
/// (and Arnoldi on so inaccurate an operator does not converge: the beam of 1e6 elements ran
/// 900 s). 1: below it the per-zero error bounds say what is left.
inline constexpr double kNoDigitConditioning = 1.0;

/// The relative accuracy to expect of the zeros nearest the shift, before computing them:
/// eps * max_i K_ii / M_ii / |lambda|^2, the machine precision times the spread between the
/// mesh's highest frequency squared and the slowest zero's |lambda|^2 (from a few power
/// iterations on OP from `start`, size 2n): the backward error of the factorisation, eps |K|,
/// over |Q'(lambda)| ~ |lambda| |M| at that zero. Grows like N^4 for Euler-Bernoulli beam
/// elements, N^2 for a chain. `workspace` must be factorised at `shift`.
double ZeroConditioningEstimate(const LinearSystem& system,
                                const LinearZeroDynamicsWorkspace& workspace,
                                const Eigen::VectorXd& start,
                                double shift);

/// Throws NoSolution, saying why and what would work, when ZeroConditioningEstimate is at least
/// kNoDigitConditioning.
void RefuseIllConditioned(const LinearSystem& system,
                          const LinearZeroDynamicsWorkspace& workspace,
                          const Eigen::VectorXd& start,
                          const LinearZeroDynamicsOptions& options);

/// The `count` members of `eigenvalues` nearest `shift`, sorted by SortEigenvalues.
std::vector<std::complex<double>> NearestEigenvalues(std::vector<std::complex<double>> eigenvalues,
                                                     double shift,
                                                     std::size_t count);

}  // namespace servokit
