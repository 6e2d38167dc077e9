#pragma once
// A thin wrapper of ARPACK-ng 3.8's dnaupd/dneupd reverse communication (Lehoucq, Sorensen &
// Yang, "ARPACK Users' Guide", SIAM 1998) for the few eigenvalues of a large nonsymmetric
// real operator, and its use in shift-invert mode for a generalized problem A x = lambda E x.
//
// Shift-invert: with a real shift sigma, the operator OP = (A - sigma E)^-1 E has the eigenvalues
// nu = 1 / (lambda - sigma); the lambda nearest sigma become the nu of largest magnitude, where
// Arnoldi converges fastest, and infinite eigenvalues of a singular E become nu = 0, where they do
// no harm. ARPACK runs here in its regular mode (iparam(7) = 1, bmat = 'I') on OP given by a
// callback; the caller factorises A - sigma E once, and every ARPACK request is one solve. ARPACK's
// own generalized mode 3 would need E symmetric positive semi-definite and E products on top;
// mode 1 on the callback needs neither, at the price of a Euclidean (not E-) inner product,
// which does not matter for a nonsymmetric problem. Only real shifts are offered: a real OP keeps
// ARPACK in real arithmetic (dnaupd); complex shifts would need znaupd and complex factorisations,
// and the zero dynamics of a real model are closed under conjugation anyway.
#include <Eigen/Dense>
#include <complex>
#include <functional>
#include <optional>
#include <string_view>
#include <vector>

namespace servokit {

/// How many Ritz values ARPACK computes and how hard it tries.
struct ArpackOptions {
  // nev: the number of eigenvalues wanted. 10 gives the slowest few modes of a structure, the
  // ones that decide its behaviour; must be at most n - 2 (ARPACK's rule ncv - nev >= 2).
  int eigenvalues = 10;
  // ncv: the Arnoldi basis size; 0 chooses max(2 eigenvalues + 10, 30), capped at n. SciPy's
  // eigs default max(2 eigenvalues + 1, 20) is too tight for conjugate pairs of nearly equal
  // spacing: the chain of 1e5 masses (k = 10) took 46 restarts and 44 s with 21 vectors, 2
  // restarts and 2.4 s with 30 (more vectors: fewer restarts, but memory n * ncv and
  // orthogonalisation ~n ncv^2 per restart; 40 took 4.3 s). Otherwise eigenvalues + 2..n.
  int basis_size = 0;
  // ARPACK's relative accuracy of the Ritz values |nu| (0: machine precision, ARPACK's default
  // when tol <= 0). 1e-12 keeps the zeros to about 12 digits where they are well conditioned
  // and halves the work against machine precision (measured: the chain of 1e4 masses 43
  // operator applications instead of 69, the beam of 1e4 elements 31 instead of 65).
  double tolerance = 1e-12;
  // Implicit restarts allowed (iparam(3)); 1000 is far beyond what shift-invert needs (a few
  // dozen) and stops a hopeless run in bounded time.
  int max_iterations = 1000;
  // CPU budget in seconds (0: none). A run that has not converged by then stops with NoSolution
  // saying so and how many eigenvalues had converged, never a claim of convergence: a model
  // whose shift-invert is too inaccurate for Arnoldi (the beam of 1e6 elements ran 900 s)
  // fails in bounded time. 60 s: a minute, the budget for a million unknowns.
  double time_limit = 60.0;
  // Also compute the Ritz vectors (dneupd with rvec = 1, written over the Arnoldi basis, so no
  // memory beyond the basis): what a per-eigenvalue residual and error bound needs.
  bool ritz_vectors = false;
  /// Throws UsageError naming the field, its value and the rule it breaks.
  void Validate() const;
};

/// Which end of the spectrum of OP ARPACK converges to.
enum class ArpackTarget {
  kLargestMagnitude,  // 'LM': in shift-invert, the lambda nearest sigma
  kLargestRealPart,   // 'LR': in shift-invert, the largest Re 1/(lambda - sigma)
};

/// What ARPACK computed and how.
struct ArpackResult {
  std::vector<std::complex<double>> ritz_values;  // converged eigenvalues of OP, in ARPACK's order
  int restarts = 0;                               // implicit restarts taken (iparam(3) on exit)
  int operator_applications = 0;                  // callback calls (iparam(9))
  int basis_size = 0;                             // ncv used
  // With ArpackOptions::ritz_vectors: n x ritz_values.size() (column-major), ARPACK's packing:
  // column j is the eigenvector of a real ritz_values[j]; for a pair with Im ritz_values[j] > 0,
  // columns j and j + 1 are the real and imaginary parts of the eigenvector of ritz_values[j]
  // (and their conjugate that of ritz_values[j + 1]). See RitzVector.
  std::vector<double> ritz_vectors;
  Eigen::Index dimension = 0;  // n
};

/// The eigenvector of result.ritz_values[index] (complex, size n) from result.ritz_vectors
/// (which must have been asked for), unpacking ARPACK's conjugate-pair layout.
Eigen::VectorXcd RitzVector(const ArpackResult& result, std::size_t index);

/// y = OP x for vectors of the size given to ArpackEigenvalues; x and y do not overlap.
using LinearOperator = std::function<void(const double* x, double* y)>;

/// The options.eigenvalues eigenvalues of the n x n operator `apply` at `target`, by dnaupd and
/// dneupd (no eigenvectors). `start`, if given (size n), is the starting vector; otherwise ARPACK
/// draws a random one. Throws UsageError for bad options (or eigenvalues > n - 2) and NoSolution
/// with ARPACK's meaning of the info code when dnaupd or dneupd fails, including "maximum number
/// of iterations taken" (with the count that did converge).
ArpackResult ArpackEigenvalues(Eigen::Index n,
                               const LinearOperator& apply,
                               ArpackTarget target,
                               const ArpackOptions& options,
                               const std::optional<Eigen::VectorXd>& start = std::nullopt);

/// Shift-invert for A x = lambda E x with a real shift: `shift_invert` applies
/// (A - shift E)^-1 E; returns the converged lambda = shift + 1/nu, dropping nu = 0 exactly
/// (an infinite eigenvalue). Throws as ArpackEigenvalues.
std::vector<std::complex<double>> ShiftInvertEigenvalues(Eigen::Index n,
                                                         const LinearOperator& shift_invert,
                                                         double shift,
                                                         ArpackTarget target,
                                                         const ArpackOptions& options,
                                                         ArpackResult* details = nullptr);

/// ARPACK's text for an info code of dnaupd (`routine` = "dnaupd") or dneupd ("dneupd").
std::string_view ArpackInfoMessage(std::string_view routine, int info);

}  // namespace servokit
